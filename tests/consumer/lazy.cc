// Links freeloc::pipeline and freeloc::io only: the networks module (LibTorch) and the image codecs must load from
// the installed prefix on first use, and not before.
#include <freeloc/core/module_loader.h>
#include <freeloc/io/image_io.h>
#include <freeloc/pipeline/networks.h>

#include <cstdio>

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  const bool torch_at_start = freeloc::ModuleLoaded("libtorch_cpu.so.1.13") || freeloc::pipeline::NetworksLoaded();
  const bool codecs_at_start = freeloc::ModuleLoaded("libfreeloc_codecs.so");
  freeloc::Image img(5, 3);
  img.data[7] = 200;
  freeloc::io::WriteImagePng(argv[1], img);
  const freeloc::Image back = freeloc::io::ReadImage(argv[1]);
  const bool codecs_after = freeloc::ModuleLoaded("libfreeloc_codecs.so");
  const auto& api = freeloc::pipeline::Networks();
  std::printf(
      "torch at start = %d, codecs at start = %d, codecs after decode = %d, round trip = %d, networks abi = %d, "
      "loaded = %d\n",
      torch_at_start, codecs_at_start, codecs_after, back.data == img.data, api.abi,
      freeloc::pipeline::NetworksLoaded());
  return !torch_at_start && !codecs_at_start && codecs_after && back.data == img.data &&
                 freeloc::pipeline::NetworksLoaded()
             ? 0
             : 1;
}

// bench/metric3d — the released vit_small and vit_large Metric3D v2 architectures (shapes from the fixture's
// list of the released state dicts, random weights) at the canonical 616×1064 input, fp32, 2 threads: median time
// after a warm-up, achieved GFLOP/s (0.64 / 5.77 TFLOP per image) next to the fp32 GEMM rate measured in this
// process, peak RSS per model (each model runs in a child process so the RSS is its own), the PyTorch reference
// measured here (vit_small 6.1 s / 1.58 GB, vit_large 34.6 s / 4.38 GB). bf16 is per-GEMM here (no AVX512-BF16).
//
//   metric3d [--threads N] [--reps R] [--only vit_small|vit_large]
#include "freeloc/nn/metric3d.h"

#include <sys/wait.h>
#include <torch/torch.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "bench_torch.h"

using freeloc::bench::Fmt;
using freeloc::bench::NowSeconds;

namespace {

// Runs one variant; writes "seconds rss_mb gemm" to fd.
void RunOne(const std::string& variant, int threads, int reps, int fd) {
  torch::set_num_threads(threads);
  const double gemm = freeloc::bench::GemmRate(3349, 1024, 4096, torch::kFloat32);
  const auto sd = freeloc::bench::RandomMetric3d(variant);
  freeloc::nn::RuntimeOptions rt;
  rt.threads = threads;
  const auto m = freeloc::nn::Metric3dModel::Create(sd, "{}", variant, rt);
  std::vector<float> in(static_cast<size_t>(3) * 616 * 1064);
  for (size_t i = 0; i < in.size(); ++i) in[i] = static_cast<float>(((i * 7919) % 255) / 127.5 - 1.0);
  freeloc::io::TensorView d, c, n;
  m->Forward(in, &d, &c, &n);  // warm-up
  std::vector<double> t;
  for (int r = 0; r < reps; ++r) {
    const double t0 = NowSeconds();
    m->Forward(in, &d, &c, &n);
    t.push_back(NowSeconds() - t0);
  }
  char buf[128];
  const int len =
      std::snprintf(buf, sizeof(buf), "%f %f %f\n", freeloc::bench::Median(t), freeloc::bench::PeakRssMB(), gemm);
  if (write(fd, buf, static_cast<size_t>(len)) < 0) std::perror("write");
}

}  // namespace

int main(int argc, char** argv) {
  int threads = 2, reps = 3;
  std::string only;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--reps") && i + 1 < argc)
      reps = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--only") && i + 1 < argc)
      only = argv[++i];
    else {
      std::fprintf(stderr, "usage: metric3d [--threads N] [--reps R] [--only vit_small|vit_large]\n");
      return 2;
    }
  }
  struct Ref {
    const char* name;
    double tflop, ref_s, ref_gb;
  };
  const Ref refs[] = {{"vit_small", 0.64, 6.1, 1.58}, {"vit_large", 5.77, 34.6, 4.38}};
  freeloc::bench::MarkdownTable t({"model", "fp32 median", "GFLOP/s", "fp32 GEMM rate (same process)", "peak RSS",
                                   "PyTorch reference here", "target"});
  for (const Ref& r : refs) {
    if (!only.empty() && only != r.name) continue;
    int p[2];
    if (pipe(p) != 0) return 1;
    const pid_t pid = fork();
    if (pid == 0) {
      close(p[0]);
      RunOne(r.name, threads, reps, p[1]);
      _exit(0);
    }
    close(p[1]);
    char buf[256] = {0};
    const ssize_t n = read(p[0], buf, sizeof(buf) - 1);
    close(p[0]);
    int status = 0;
    waitpid(pid, &status, 0);
    double s = 0, rss = 0, gemm = 0;
    if (n <= 0 || std::sscanf(buf, "%lf %lf %lf", &s, &rss, &gemm) != 3) {
      std::fprintf(stderr, "bench/metric3d: %s failed\n", r.name);
      return 1;
    }
    t.Row({r.name, Fmt("%.2f s", s), Fmt("%.1f", r.tflop * 1000 / s), Fmt("%.1f GFLOP/s", gemm),
           Fmt("%.2f GB", rss / 1024.0), Fmt("%.1f s, ", r.ref_s) + Fmt("%.2f GB", r.ref_gb),
           (s <= r.ref_s ? "time met" : "time missed") +
               std::string(rss / 1024.0 <= r.ref_gb ? ", RSS met" : ", RSS missed")});
  }
  std::printf("## bench/metric3d — 616×1064, random weights, %d threads, median of %d after a warm-up\n\n", threads,
              reps);
  t.Print();
  std::printf("\nbf16: not run — on CPUs without AVX512-BF16 LibTorch's bf16 GEMM is emulated (see bench/gemm).\n");
  return 0;
}

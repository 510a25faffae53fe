// Uses core and io through the installed headers and libraries.
#include <freeloc/core/rigid3d.h>
#include <freeloc/io/safetensors.h>

#include <cstdio>

int main(int argc, char** argv) {
  const freeloc::Rigid3d query_from_ref = freeloc::Rigid3d::FromWxyz({1, 0, 0, 0}, Eigen::Vector3d(0, 0, -2));
  std::printf("centre z = %.1f\n", query_from_ref.Center().z());
  if (argc > 1) {
    const auto f = freeloc::io::SafetensorsFile::Open(argv[1]);
    std::printf("tensors = %zu\n", f.names.size());
  }
  return query_from_ref.Center().z() == 2.0 ? 0 : 1;
}

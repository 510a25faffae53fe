// bench/gemm — the fp32 and bf16 GEMM rate LibTorch reaches here with the configured threads. Every later
// performance figure (DUSt3R, SegGPT, Metric3D) is reported next to this number, measured in the same process.
//
//   gemm [--threads N] [--reps R] [--dtype all|fp32|bf16]     (default: 2 threads, median of 5, both dtypes)
#include <torch/torch.h>

#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "bench_util.h"

using freeloc::bench::Fmt;

namespace {

struct Shape {
  int64_t m, k, n;
  const char* what;
};

// Median seconds of `reps` timed runs after one warm-up.
double TimeMatmul(const Shape& s, torch::Dtype dtype, int reps) {
  torch::InferenceMode guard;
  auto a = torch::randn({s.m, s.k}).to(dtype);
  auto b = torch::randn({s.k, s.n}).to(dtype);
  auto c = torch::matmul(a, b);  // warm-up
  std::vector<double> t;
  for (int r = 0; r < reps; ++r) {
    const double t0 = freeloc::bench::NowSeconds();
    c = torch::matmul(a, b);
    t.push_back(freeloc::bench::NowSeconds() - t0);
  }
  return freeloc::bench::Median(t);
}

// The BLAS library actually mapped into this process (Debian's LibTorch calls the generic libblas.so.3, which the
// alternatives system points at OpenBLAS when scripts/install-deps.sh has run).
std::string LoadedBlas() {
  std::FILE* f = std::fopen("/proc/self/maps", "r");
  if (!f) return "unknown";
  char line[1024];
  std::string found;
  while (std::fgets(line, sizeof(line), f)) {
    std::string l(line);
    if (l.find("blas") == std::string::npos) continue;
    const size_t p = l.find('/');
    if (p == std::string::npos) continue;
    std::string path = l.substr(p);
    while (!path.empty() && (path.back() == '\n' || path.back() == ' ')) path.pop_back();
    if (found.find(path) == std::string::npos) found += (found.empty() ? "" : ", ") + path;
  }
  std::fclose(f);
  return found.empty() ? "none mapped" : found;
}

std::string BlasInfo() {
  const std::string cfg = torch::show_config();
  for (const char* key : {"BLAS_INFO=", "LAPACK_INFO="}) {
    const size_t p = cfg.find(key);
    if (p != std::string::npos) {
      const size_t e = cfg.find_first_of(",\n", p);
      return cfg.substr(p, e - p);
    }
  }
  return "unknown";
}

}  // namespace

int main(int argc, char** argv) {
  int threads = 2, reps = 5;
  std::string which = "all";
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--reps") && i + 1 < argc)
      reps = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--dtype") && i + 1 < argc)
      which = argv[++i];
    else {
      std::fprintf(stderr, "usage: gemm [--threads N] [--reps R] [--dtype all|fp32|bf16]\n");
      return 2;
    }
  }
  torch::set_num_threads(threads);
  std::printf("%s\n\n", freeloc::bench::MachineLine().c_str());
  std::printf("## bench/gemm — LibTorch %s, %d threads (torch::get_num_threads() = %d), %s, median of %d\n\n",
              TORCH_VERSION, threads, torch::get_num_threads(), BlasInfo().c_str(), reps);
  const std::vector<Shape> shapes = {
      {768, 1024, 4096, "DUSt3R encoder MLP fc1 (512x384)"},
      {1024, 1024, 1024, "square 1024"},
      {2048, 2048, 2048, "square 2048"},
  };
  freeloc::bench::MarkdownTable table({"dtype", "M×K×N", "what", "median ms", "GFLOP/s"});
  for (auto dtype : {torch::kFloat32, torch::kBFloat16}) {
    if (which != "all" && which != (dtype == torch::kFloat32 ? "fp32" : "bf16")) continue;
    for (const auto& s : shapes) {
      const double sec = TimeMatmul(s, dtype, reps);
      const double gflops = 2.0 * s.m * s.k * s.n / sec / 1e9;
      table.Row({dtype == torch::kFloat32 ? "fp32" : "bf16",
                 std::to_string(s.m) + "×" + std::to_string(s.k) + "×" + std::to_string(s.n), s.what,
                 Fmt("%.1f", sec * 1e3), Fmt("%.1f", gflops)});
    }
  }
  table.Print();
  std::printf("\nBLAS libraries mapped: %s\n", LoadedBlas().c_str());
  std::printf("\npeak RSS: %.0f MB\n", freeloc::bench::PeakRssMB());
  return 0;
}

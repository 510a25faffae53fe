// bench/relocalize — what a query costs a user, per preset, at the released architectures (random full-size weights:
// DUSt3R / MASt3R ViT-L + base decoder at 512, SegGPT ViT-L, Metric3D v2 vit_large unless --metric3d says otherwise)
// on map-free-sized 540×720 portrait images, through the same Relocalizer `freeloc run` uses (the network stages
// are the networks module's, built on the in-memory models). For each preset: the reference side once (its depth,
// encodings, instance encodings), then per query a stage table — depth, the pair's network pass, the query's
// own-pointmap pass (the pair swapped: the focal check, MASt3R's query depth), global matching,
// SegGPT propagation, the masked pairs' network passes, instance matching + merge, solve — the total, the FLOP the
// networks executed (counted at the LibTorch dispatcher: mm/addmm/bmm/convolution) and the achieved GFLOP/s against
// the best GEMM rate (of the run's precision) measured in this process right before and after the preset's queries, the
// resident memory with every model loaded and the peak during the timed queries (VmHWM reset before them); one untimed
// query first (one-time kernel costs). The reference gives K rectangular instances; SegGPT propagates them (its output
// bias is set so that every instance is painted over the whole query and its filters are off: with random weights the
// masks are noise, and the point is the work every instance costs).
//
//   relocalize [--threads N] [--queries Q] [--presets a,b,…] [--instances K] [--metric3d
//   vit_small|vit_large|vit_giant2]
//              [--precision fp32|bf16|fp32,bf16] [--set NAME=VALUE …]   (an option for every preset, e.g.
//              sprt_min_matches=0)
//   relocalize --phone   phone photos (12 and 48 MP JPEGs, 256×192 depth) against the VGA pair: phone_photos.h
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <random>
#include <sstream>

#include "bench_torch.h"
#include "freeloc/networks/network_stages.h"
#include "freeloc/nn/dust3r.h"
#include "freeloc/nn/internal/bf16_linear.h"
#include "freeloc/nn/metric3d.h"
#include "freeloc/nn/seggpt.h"
#include "freeloc/pipeline/relocalizer.h"
#include "phone_photos.h"

using freeloc::bench::Fmt;
using freeloc::bench::NowSeconds;
namespace pl = freeloc::pipeline;

namespace {

constexpr int kW = 540, kH = 720;

// A textured 540×720 photo: smooth shading, seeded random rectangles and discs (SIFT finds corners, SegGPT and the
// instance masks have regions), seen from a shifted viewpoint for the query (`shift` px, `zoom`).
freeloc::Image Photo(double shift, double zoom) {
  std::mt19937 rng(1234);  // the same scene for every view
  std::uniform_real_distribution<double> u(0, 1);
  struct Shape {
    double x, y, r, g, b, size;
    bool disc;
  };
  std::vector<Shape> shapes(180);
  for (auto& s : shapes)
    s = {u(rng) * kW, u(rng) * kH, u(rng) * 255, u(rng) * 255, u(rng) * 255, 8 + u(rng) * 40, u(rng) < 0.5};
  freeloc::Image img(kW, kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const double sx = (x - kW / 2.0) / zoom + kW / 2.0 + shift, sy = (y - kH / 2.0) / zoom + kH / 2.0;
      double c[3] = {90 + 60 * std::sin(sx * 0.013) + 20 * std::cos(sy * 0.021), 110 + 50 * std::cos(sy * 0.011),
                     120 + 40 * std::sin((sx + sy) * 0.009)};
      for (const auto& s : shapes) {
        const double dx = sx - s.x, dy = sy - s.y;
        if (s.disc ? dx * dx + dy * dy < s.size * s.size : std::abs(dx) < s.size && std::abs(dy) < s.size * 0.6) {
          c[0] = s.r;
          c[1] = s.g;
          c[2] = s.b;
        }
      }
      for (int k = 0; k < 3; ++k)
        img.data[(static_cast<size_t>(y) * kW + x) * 3 + k] = static_cast<uint8_t>(std::clamp(c[k], 0.0, 255.0));
    }
  return img;
}

// K rectangles on a grid as an instance label image (1..K).
std::vector<uint16_t> Instances(int k) {
  std::vector<uint16_t> l(static_cast<size_t>(kW) * kH, 0);
  const int cols = 2;
  for (int i = 0; i < k; ++i) {
    const int cx = (i % cols) * kW / cols + kW / (2 * cols), cy = (i / cols) * 160 + 140;
    for (int y = std::max(0, cy - 60); y < std::min(kH, cy + 60); ++y)
      for (int x = std::max(0, cx - 90); x < std::min(kW, cx + 90); ++x) l[static_cast<size_t>(y) * kW + x] = i + 1;
  }
  return l;
}

std::vector<std::string> Split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string t; std::getline(ss, t, ',');)
    if (!t.empty()) out.push_back(t);
  return out;
}

struct Row {
  std::string preset;
  double ref_s = 0, total_s = 0, gflop = 0, gflops = 0;
  double depth = 0, pair = 0, own = 0, match = 0, seg = 0, inst_pass = 0, inst_match = 0, solve = 0, other = 0;
  int instances = 0, pairs = 0, matches = 0;
  double rss_mb = 0, peak_mb = 0;  // resident before the timed queries (every model loaded), and their peak
  double gemm = 0;                 // the best GEMM rate measured right before and right after the timed queries
  std::string status;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && !std::strcmp(argv[1], "--phone")) {
    const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
    return phone::Main(std::filesystem::path(self).parent_path().parent_path() / "freeloc", FREELOC_SOURCE_DIR,
                       FREELOC_TINY_MODELS_DIR);
  }
  int threads = 2, queries = 1, instances = 4;
  std::string presets = "seed,seed-no-instance,dust3r,mast3r,mast3r-metric3d,seed-mast3r,sift-essential";
  std::string m3d_variant = "vit_large", precision = "fp32";
  std::vector<std::pair<std::string, std::string>> overrides;  // --set NAME=VALUE, for every preset
  bool memory_lines = false;            // a child of a two-precision run: also print "MEMORY preset rest peak" lines
  std::vector<std::string> child_args;  // the arguments without --precision, for the children
  for (int i = 1; i < argc; ++i)
    if (std::strcmp(argv[i], "--precision") != 0 && std::strcmp(argv[i - 1], "--precision") != 0)
      child_args.push_back(argv[i]);
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--memory-lines"))
      memory_lines = true;
    else if (!std::strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--queries") && i + 1 < argc)
      queries = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--presets") && i + 1 < argc)
      presets = argv[++i];
    else if (!std::strcmp(argv[i], "--instances") && i + 1 < argc)
      instances = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--metric3d") && i + 1 < argc)
      m3d_variant = argv[++i];
    else if (!std::strcmp(argv[i], "--precision") && i + 1 < argc)
      precision = argv[++i];
    else if (!std::strcmp(argv[i], "--set") && i + 1 < argc && std::strchr(argv[i + 1], '=')) {
      const std::string kv = argv[++i];
      overrides.emplace_back(kv.substr(0, kv.find('=')), kv.substr(kv.find('=') + 1));
    } else {
      std::fprintf(stderr,
                   "usage: relocalize [--threads N] [--queries Q] [--presets a,b,…] [--instances K] "
                   "[--metric3d vit_small|vit_large|vit_giant2] [--precision fp32|bf16|fp32,bf16] "
                   "[--set NAME=VALUE …]\n");
      return 2;
    }
  }
  // One pass per precision (--precision fp32,bf16 runs each in a child process, below): each builds its models,
  // prints its tables and gives back each preset's resident memory and query peak.
  struct Memory {
    double rest_mb = 0, peak_mb = 0;
  };
  const auto run = [&](const std::string& precision) {
    std::map<std::string, Memory> memory;
    torch::set_num_threads(threads);
    const bool bf16 = precision == "bf16";
    // The machine's GEMM rate in this process: torch's matmul, and in bf16 also the prepacked oneDNN kernel the
    // networks' Linear layers run (768×1024 by 1024×4096), each the best of 7 runs. Measured before the presets, after
    // them, and right before and after each preset's timed queries: a shared machine's speed drifts over a run (the
    // same kernel measured 309 and 435 GFLOP/s minutes apart on one VM), so each preset's rates are against the best
    // rate measured around its own queries — the faster kernel, the better of the two measurements.
    const freeloc::nn::internal::PackedLinearBf16* packed_lin = nullptr;
    std::unique_ptr<freeloc::nn::internal::PackedLinearBf16> packed_owner;
    torch::Tensor gemm_x;
    if (bf16) {
      torch::InferenceMode guard;
      gemm_x = torch::randn({768, 1024});
      packed_owner =
          std::make_unique<freeloc::nn::internal::PackedLinearBf16>(torch::randn({4096, 1024}) * 0.03, torch::Tensor());
      packed_lin = packed_owner.get();
    }
    double gemm_torch = 0, gemm_packed = 0;
    // Returns the faster kernel's rate in this measurement; gemm_torch / gemm_packed keep the process-wide best.
    const auto measure_gemm = [&] {
      torch::InferenceMode guard;
      const double torch_rate =
          freeloc::bench::GemmRate(768, 1024, 4096, bf16 ? torch::kBFloat16 : torch::kFloat32, 7, true);
      gemm_torch = std::max(gemm_torch, torch_rate);
      double packed_rate = 0;
      if (packed_lin) {
        (void)(*packed_lin)(gemm_x);
        double best = 1e30;
        for (int r = 0; r < 7; ++r) {
          const double t0 = NowSeconds();
          (void)(*packed_lin)(gemm_x);
          best = std::min(best, NowSeconds() - t0);
        }
        packed_rate = 2.0 * 768 * 1024 * 4096 / best / 1e9;
        gemm_packed = std::max(gemm_packed, packed_rate);
      }
      return std::max(torch_rate, packed_rate);
    };
    measure_gemm();
    freeloc::nn::RuntimeOptions rt;
    rt.threads = threads;
    rt.precision = freeloc::ParseEnum<freeloc::nn::Precision>(precision, "--precision");
    const std::string shared = FREELOC_SHARED_DIR;

    // Models, built once (only those the presets need).
    const auto want = Split(presets);
    auto needs = [&](const char* what) {
      for (const auto& p : want) {
        const auto o = pl::ResolvePreset(p);
        if (!std::strcmp(what, "dust3r") && o.UsesDust3r()) return true;
        if (!std::strcmp(what, "mast3r") && o.UsesMast3r()) return true;
        if (!std::strcmp(what, "seggpt") && o.UsesSegGpt()) return true;
        if (!std::strcmp(what, "metric3d") && o.UsesMetric3d()) return true;
      }
      return false;
    };
    const double t_load = NowSeconds();
    std::shared_ptr<freeloc::nn::Dust3rModel> dust3r, mast3r;
    std::shared_ptr<freeloc::nn::SegGptModel> seggpt;
    std::shared_ptr<freeloc::nn::Metric3dModel> metric3d;
    if (needs("dust3r"))
      dust3r = freeloc::nn::Dust3rModel::Create(
          freeloc::bench::RandomFullModel(shared + "/fixtures/dust3r/full_model_state_dict_shapes.json"),
          {{"enc_num_heads", "16"}, {"dec_num_heads", "12"}, {"pos_embed", "RoPE100"}}, "random", rt);
    if (needs("mast3r"))
      mast3r = freeloc::nn::Dust3rModel::Create(
          freeloc::bench::RandomFullModel(shared + "/fixtures/mast3r/full_model_state_dict_shapes.json"),
          {{"enc_num_heads", "16"},
           {"dec_num_heads", "12"},
           {"pos_embed", "RoPE100"},
           {"head_type", "catmlp+dpt"},
           {"output_mode", "pts3d+desc24"},
           {"two_confs", "True"},
           {"desc_conf_mode", "('exp', 0, inf)"}},
          "random", rt);
    if (needs("seggpt")) {
      auto sd = freeloc::bench::RandomSegGpt();
      // Random weights paint noise, so a propagated mask could be empty and its masked pair would be skipped: a large
      // output bias paints every pixel white, i.e. each instance propagates to the whole query and every masked pair
      // runs (the same network work as with trained weights; the masks' content does not change the cost).
      sd["decoder_pred.3.bias"] = freeloc::nn::internal::ToView(torch::full({3}, 5.0));
      seggpt = freeloc::nn::SegGptModel::Create(sd, R"({"img_size": [896, 448], "num_heads": 16})", "random", rt);
    }
    if (needs("metric3d"))
      metric3d = freeloc::nn::Metric3dModel::Create(freeloc::bench::RandomMetric3d(m3d_variant), "{}", m3d_variant, rt);
    freeloc::nn::ReleaseFreedMemory();  // as the networks' model cache does after a load
    const double load_s = NowSeconds() - t_load;
    const double loaded_mb = freeloc::bench::ProcStatusMB("VmRSS");

    // One scene: the reference, Q queries (shifted and zoomed views), K reference instances, 2 m provided depth.
    freeloc::Camera cam;
    cam.fx = cam.fy = 590;
    cam.cx = kW / 2.0;
    cam.cy = kH / 2.0;
    cam.width = kW;
    cam.height = kH;
    const freeloc::Image ref = Photo(0, 1.0);
    std::vector<freeloc::Image> qs;
    for (int q = 0; q < queries; ++q) qs.push_back(Photo(14.0 + 6 * q, 1.04 + 0.02 * q));
    const std::vector<uint16_t> labels = Instances(instances);
    freeloc::DepthMap depth(kW, kH);
    std::fill(depth.data.begin(), depth.data.end(), 2.0f);

    std::vector<Row> rows;
    for (const auto& name : want) {
      pl::PipelineOptions o = pl::ResolvePreset(name);
      o.runtime = rt;
      o.pointmap.dust3r_size = 512;
      o.instances.segmenter.min_score = 0;
      o.instances.segmenter.min_area_ratio = 0;
      o.instances.segmenter.max_area_ratio = 1e9;
      for (const auto& [name, value] : overrides) pl::SetOption(&o, name, value);
      for (std::string* p :
           {&o.models.dust3r_model, &o.models.mast3r_model, &o.models.seggpt_model, &o.models.metric3d_model})
        *p = "random";
      std::unique_ptr<pl::Matcher> matcher =
          o.UsesPointmapModel() ? freeloc::networks::MakeNetworkMatcher(o, o.UsesMast3r() ? mast3r : dust3r, seggpt)
                                : pl::MakeMatcher(o);
      std::unique_ptr<pl::DepthEstimator> dest =
          o.UsesMetric3d() ? freeloc::networks::MakeNetworkDepthEstimator(metric3d) : pl::MakeDepthEstimator(o);
      pl::Relocalizer reloc(o, std::move(matcher), std::move(dest), pl::MakePoseSolver(o));
      Row row;
      row.preset = name;
      pl::FrameInputs rin;
      rin.depth = depth;
      if (o.UsesInstances()) rin.instance_labels = &labels;
      double t0 = NowSeconds();
      reloc.SetReference(ref, cam, rin);
      row.ref_s = NowSeconds() - t0;
      // One untimed query first: the first call of each kernel shape pays one-time costs (oneDNN JIT code for bf16,
      // thread pools) that a scene's hundreds of queries do not.
      // It also counts the query's network FLOP (the same for every query of the scene): the counter's callback costs
      // time on networks with many small ops (Metric3D's refinement loop), so the timed queries run without it.
      double query_gflop = 0;
      {
        const freeloc::bench::FlopCounter counter;
        const double f0 = freeloc::bench::FlopCounter::Total();
        pl::FrameInputs qin;
        qin.depth = depth;
        reloc.Relocalize(qs.front(), cam, qin);
        query_gflop = (freeloc::bench::FlopCounter::Total() - f0) / 1e9;
      }
      std::vector<Row> per;
      const double gemm_before = measure_gemm();
      const double rss_mb = freeloc::bench::ProcStatusMB("VmRSS");
      const bool peak_reset = freeloc::bench::ResetPeakRss();
      for (const auto& q : qs) {
        pl::FrameInputs qin;
        qin.depth = depth;
        t0 = NowSeconds();
        const pl::QueryResult r = reloc.Relocalize(q, cam, qin);
        Row x;
        x.total_s = NowSeconds() - t0;
        x.gflop = query_gflop;
        x.depth = r.timings.depth_ms / 1e3;
        x.pair = r.timings.pair_ms / 1e3;
        x.own = r.timings.own_pass_ms / 1e3;
        x.match = std::max(0.0, r.timings.match_ms - r.timings.pair_ms - r.timings.own_pass_ms) / 1e3;
        x.seg = r.timings.segment_ms / 1e3;
        x.inst_pass = r.timings.instance_pass_ms / 1e3;
        x.inst_match = std::max(0.0, r.timings.instance_ms - r.timings.segment_ms - r.timings.instance_pass_ms) / 1e3;
        x.solve = r.timings.solve_ms / 1e3;
        x.other = std::max(
            0.0, x.total_s - x.depth - x.pair - x.own - x.match - x.seg - x.inst_pass - x.inst_match - x.solve);
        x.instances = r.instances;
        x.pairs = r.timings.instance_pairs;
        x.matches = r.matches;
        x.status = r.StatusText().substr(0, 24);
        per.push_back(x);
      }
      row.gemm = std::max(gemm_before, measure_gemm());
      auto med = [&](double Row::*f) {
        std::vector<double> v;
        for (const auto& x : per) v.push_back(x.*f);
        return freeloc::bench::Median(v);
      };
      row.total_s = med(&Row::total_s);
      row.gflop = med(&Row::gflop);
      row.gflops = row.gflop / row.total_s;
      row.depth = med(&Row::depth);
      row.pair = med(&Row::pair);
      row.own = med(&Row::own);
      row.match = med(&Row::match);
      row.seg = med(&Row::seg);
      row.inst_pass = med(&Row::inst_pass);
      row.inst_match = med(&Row::inst_match);
      row.solve = med(&Row::solve);
      row.other = med(&Row::other);
      row.instances = per.back().instances;
      row.pairs = per.back().pairs;
      row.matches = per.back().matches;
      row.status = per.back().status;
      row.rss_mb = rss_mb;
      row.peak_mb = peak_reset ? freeloc::bench::ProcStatusMB("VmHWM") : 0;
      rows.push_back(row);
      std::fprintf(stderr, "%s: reference %.1f s, query %.1f s\n", name.c_str(), row.ref_s, row.total_s);
    }

    measure_gemm();  // again, after the presets
    const double gemm = std::max(gemm_torch, gemm_packed);
    std::printf("%s\n\n", freeloc::bench::MachineLine().c_str());
    std::printf(
        "## bench/relocalize — per-query cost of each preset, released architectures (random weights), 540×720 "
        "images, %d threads, %s, Metric3D %s, %d reference instances, median of %d quer%s after one untimed query\n\n",
        threads, precision.c_str(), m3d_variant.c_str(), instances, queries, queries == 1 ? "y" : "ies");
    std::printf(
        "Models built in %.1f s (resident then: %.0f MB). GEMM rate in this process (768×1024×4096, %s, best of 7 "
        "runs, "
        "measured before, between and after the presets): torch::matmul up to %.1f GFLOP/s%s, the best %.1f GFLOP/s; "
        "each preset's rates are against the best rate measured right before and right after its own timed queries "
        "(the faster kernel; column \"GEMM rate around its queries\").\n\n",
        load_s, loaded_mb, precision.c_str(), gemm_torch,
        gemm_packed > 0 ? Fmt(", prepacked oneDNN kernel up to %.1f GFLOP/s", gemm_packed).c_str() : "", gemm);
    freeloc::bench::MarkdownTable t({"preset", "reference (once)", "query total", "network GFLOP / query",
                                     "achieved GFLOP/s (whole query)", "GEMM rate around its queries",
                                     "% of best GEMM rate", "networks alone: GFLOP/s (%)", "RSS at rest (MB)",
                                     "peak RSS in a query (MB)", "status"});
    for (const auto& r : rows) {
      // The networks' own rate: their FLOP over the time of the stages that run them (depth, the pair's pass and
      // its swapped pass, SegGPT, the masked pairs' passes) — the FLOP counter counts every one of them.
      const double net_s = r.depth + r.pair + r.own + r.seg + r.inst_pass;
      const double net = net_s > 0 ? r.gflop / net_s : 0;
      t.Row({r.preset, Fmt("%.2f s", r.ref_s), Fmt("%.2f s", r.total_s), Fmt("%.0f", r.gflop), Fmt("%.1f", r.gflops),
             Fmt("%.1f", r.gemm), Fmt("%.0f %%", 100 * r.gflops / r.gemm),
             net > 0 ? Fmt("%.1f", net) + Fmt(" (%.0f %%)", 100 * net / r.gemm) : "–", Fmt("%.0f", r.rss_mb),
             r.peak_mb > 0 ? Fmt("%.0f", r.peak_mb) : "–", r.status});
    }
    t.Print();
    std::printf(
        "\nWhere a query's time goes (seconds; SegGPT and the masked pairs: K instances propagated / pairs run):\n\n");
    freeloc::bench::MarkdownTable s({"preset", "depth", "pair network pass", "own-pointmap pass", "global matching",
                                     "SegGPT", "masked pairs' passes", "instance matching + merge", "solve (matches)",
                                     "other"});
    for (const auto& r : rows)
      s.Row({r.preset, Fmt("%.2f", r.depth), Fmt("%.2f", r.pair), r.own > 0 ? Fmt("%.2f", r.own) : "–",
             Fmt("%.2f", r.match), r.instances ? Fmt("%.2f", r.seg) + " (" + std::to_string(r.instances) + ")" : "–",
             r.instances ? Fmt("%.2f", r.inst_pass) + " (" + std::to_string(r.pairs) + ")" : "–",
             r.instances ? Fmt("%.2f", r.inst_match) : "–",
             Fmt("%.3f", r.solve) + " (" + std::to_string(r.matches) + ")", Fmt("%.2f", r.other)});
    s.Print();
    for (const auto& r : rows) memory[r.preset] = {r.rss_mb, r.peak_mb};
    return memory;
  };
  const auto precisions = Split(precision);
  std::vector<std::map<std::string, Memory>> memory;
  if (precisions.size() == 2) {
    // Each precision in a child process of its own: run one after the other in one process, the second inherits the
    // first's heap (freed blocks glibc keeps), which once made bf16 look 0.83× fp32 when it is 0.71×.
    for (const auto& p : precisions) {
      std::string cmd = "'" + std::string(argv[0]) + "' --memory-lines --precision " + p;
      for (const auto& a : child_args) {
        std::string q;
        for (char c : a) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
        cmd += " '" + q + "'";
      }
      FILE* child = popen(cmd.c_str(), "r");
      if (!child) {
        std::fprintf(stderr, "relocalize: cannot start %s\n", cmd.c_str());
        return 1;
      }
      std::map<std::string, Memory> mem;
      char line[4096];
      while (std::fgets(line, sizeof(line), child)) {
        char name[256];
        Memory m;
        if (std::sscanf(line, "MEMORY %255s %lf %lf", name, &m.rest_mb, &m.peak_mb) == 3)
          mem[name] = m;
        else
          std::fputs(line, stdout);
      }
      std::fflush(stdout);
      if (pclose(child) != 0) {
        std::fprintf(stderr, "relocalize: the %s pass failed\n", p.c_str());
        return 1;
      }
      memory.push_back(mem);
    }
  } else {
    for (const auto& p : precisions) memory.push_back(run(p));
    if (memory_lines)
      for (const auto& [preset, m] : memory.back())
        std::printf("MEMORY %s %f %f\n", preset.c_str(), m.rest_mb, m.peak_mb);
  }
  if (precisions.size() == 2) {
    // The memory a precision needs against the other's, for each preset (bf16 ÷ fp32 when run in that order).
    std::printf("\nMemory, %s against %s (MB; each in a process of its own with only its own models loaded):\n\n",
                precisions[1].c_str(), precisions[0].c_str());
    freeloc::bench::MarkdownTable m({"preset", "at rest " + precisions[0], "at rest " + precisions[1], "ratio",
                                     "query peak " + precisions[0], "query peak " + precisions[1], "ratio"});
    for (const auto& [preset, a] : memory[0]) {
      const auto it = memory[1].find(preset);
      if (it == memory[1].end()) continue;
      const Memory& b = it->second;
      m.Row({preset, Fmt("%.0f", a.rest_mb), Fmt("%.0f", b.rest_mb), Fmt("%.2f", b.rest_mb / a.rest_mb),
             Fmt("%.0f", a.peak_mb), Fmt("%.0f", b.peak_mb), a.peak_mb > 0 ? Fmt("%.2f", b.peak_mb / a.peak_mb) : "–"});
    }
    m.Print();
  }
  return 0;
}

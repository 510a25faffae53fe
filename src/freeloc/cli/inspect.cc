// `freeloc inspect FILE`: a checkpoint's tensors (name, dtype, shape), its metadata and, for DUSt3R .pth files,
// the model constructor string (args.model).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <string>

#include "freeloc/cli/commands.h"
#include "freeloc/io/checkpoint.h"

namespace freeloc::cli {

namespace {

struct InspectOptions {
  std::string path;
  std::string filter;
  bool names_only = false;
};

std::string HumanBytes(double b) {
  const char* units[] = {"B", "KB", "MB", "GB", "TB"};
  int u = 0;
  while (b >= 1000 && u < 4) {
    b /= 1000;
    ++u;
  }
  char buf[32];
  std::snprintf(buf, sizeof(buf), u == 0 ? "%.0f %s" : "%.2f %s", b, units[u]);
  return buf;
}

std::string OneLine(std::string s, size_t max_len = 400) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  if (s.size() > max_len) s = s.substr(0, max_len) + "…";
  return s;
}

int RunInspect(const InspectOptions& o) {
  const io::Checkpoint ckpt = io::Checkpoint::Open(o.path);
  size_t total_bytes = 0;
  int64_t total_elems = 0;
  size_t name_w = 4, dtype_w = 5;
  std::vector<std::string> shown;
  for (const auto& n : ckpt.names()) {
    const io::TensorView& t = ckpt.Get(n);
    total_bytes += t.nbytes;
    total_elems += t.numel();
    if (!o.filter.empty() && n.find(o.filter) == std::string::npos) continue;
    shown.push_back(n);
    name_w = std::max(name_w, std::min<size_t>(SafeText(n, 4096).size(), 120));
    dtype_w = std::max(dtype_w, std::string(io::DTypeTorchName(t.dtype)).size());
  }
  // Names and metadata come from the file: printed through SafeText, so escape codes cannot reach the terminal.
  std::printf("file:     %s\n", SafeText(o.path, 4096).c_str());
  std::printf("format:   %s\n", ckpt.format_name());
  std::printf("tensors:  %zu (%lld elements, %s)\n", ckpt.size(), static_cast<long long>(total_elems),
              HumanBytes(static_cast<double>(total_bytes)).c_str());
  if (ckpt.format() == io::Checkpoint::Format::kPth && !ckpt.StateDictRoot().empty()) {
    std::printf("state dict under: '%s'\n", SafeText(ckpt.StateDictRoot(), 4096).c_str());
  }
  const std::string model = ckpt.MetadataOr("args.model", "");
  if (!model.empty()) std::printf("model constructor (args.model): %s\n", SafeText(model, 4096).c_str());
  if (!ckpt.metadata().empty() && !o.names_only) {
    std::printf("\nmetadata (%zu):\n", ckpt.metadata().size());
    for (const auto& [k, v] : ckpt.metadata())
      std::printf("  %s = %s\n", SafeText(k, 4096).c_str(), SafeText(OneLine(v), 4096).c_str());
  }
  std::printf("\n%-*s  %-*s  %s\n", static_cast<int>(name_w), "name", static_cast<int>(dtype_w), "dtype", "shape");
  for (const auto& n : shown) {
    if (o.names_only) {
      std::printf("%s\n", SafeText(n, 4096).c_str());
      continue;
    }
    const io::TensorView& t = ckpt.Get(n);
    std::printf("%-*s  %-*s  %s\n", static_cast<int>(name_w), SafeText(n, 4096).c_str(), static_cast<int>(dtype_w),
                io::DTypeTorchName(t.dtype), t.ShapeString().c_str());
  }
  if (!o.filter.empty())
    std::printf("(%zu of %zu tensors match '%s')\n", shown.size(), ckpt.size(), SafeText(o.filter).c_str());
  return 0;
}

}  // namespace

void RegisterInspect(CLI::App& app, const GlobalOptions& /*global*/, RunFn* run) {
  auto opts = std::make_shared<InspectOptions>();
  auto* sub = app.add_subcommand("inspect",
                                 "List a checkpoint's tensors (name, dtype, shape) and metadata "
                                 "(.pth or .safetensors)");
  sub->add_option("FILE", opts->path, "checkpoint file (.pth zip checkpoint or .safetensors)")->required();
  sub->add_option("--filter", opts->filter, "only tensors whose name contains this text");
  sub->add_flag("--names", opts->names_only, "print tensor names only");
  sub->callback([opts, run] { *run = [opts] { return RunInspect(*opts); }; });
}

}  // namespace freeloc::cli

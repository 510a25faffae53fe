#include "freeloc/eval/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/mapfree.h"

namespace freeloc::eval {

namespace {

std::string F(const char* fmt, double v) { return FormatNumber(fmt, v); }

// Non-finite metrics are written as the official evaluator's json.dumps writes them (Infinity, -Infinity, NaN; Python's
// json.loads reads them back): a marked string in the tree, replaced by the bare token when dumped (JsonDump).
const char kNonFinite[] = "\x01nonfinite:";

std::string NonFiniteToken(double v) { return std::isnan(v) ? "NaN" : v > 0 ? "Infinity" : "-Infinity"; }

nlohmann::json Num(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(std::string(kNonFinite) + NonFiniteToken(v));
}

std::string JsonDump(const nlohmann::ordered_json& j, int indent) {
  std::string out = j.dump(indent);
  const std::string mark = "\"\\u0001nonfinite:";
  for (size_t k = out.find(mark); k != std::string::npos; k = out.find(mark, k)) {
    const size_t end = out.find('"', k + mark.size());
    out.replace(k, end + 1 - k, out.substr(k + mark.size(), end - k - mark.size()));
  }
  return out;
}

nlohmann::ordered_json MetricsJson(const Metrics& m) {
  nlohmann::ordered_json j;
  const auto v = MetricValues(m);
  for (int i = 0; i < 8; ++i) j[kMetricNames[i]] = Num(v[i]);
  return j;
}

}  // namespace

std::string EscapeMarkup(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string FormatNumber(const char* fmt, double v) {
  if (!std::isfinite(v)) return NonFiniteToken(v);  // as the JSON says it
  char b[64];
  // Fixed notation of a huge value (an extreme estimate) would be cut at the buffer: the same value in e-notation.
  std::snprintf(b, sizeof(b), std::abs(v) >= 1e12 ? "%.6e" : fmt, v);
  return b;
}

EvalRun RunEvaluation(const std::string& split_dir, const std::vector<std::string>& scenes,
                      const std::string& submission_path, io::Track track) {
  const io::ZipContents zip = io::ZipContents::Read(submission_path);
  EvalRun run;
  run.label = std::filesystem::path(submission_path).filename().string();
  // Entries the evaluator never reads: say so (folders inside the ZIP are a common mistake).
  for (const auto& n : zip.names) {
    const bool at_root = n.find('/') == std::string::npos;
    const bool pose = at_root && n.rfind("pose_", 0) == 0 && n.size() > 9 && n.compare(n.size() - 4, 4, ".txt") == 0;
    if (!pose) {
      FREELOC_LOG(WARNING) << submission_path << ": entry '" << n
                           << "' is not a pose_<scene>.txt file at the ZIP's root "
                           << "and is ignored (as by the official evaluator)";
    } else if (std::find(scenes.begin(), scenes.end(), n.substr(5, n.size() - 9)) == scenes.end()) {
      FREELOC_LOG(WARNING) << submission_path << ": " << n << " is for a scene outside the evaluated set";
    }
  }
  EvalInput in;
  in.split_dir = split_dir;
  in.scenes = scenes;
  in.submission_path = submission_path;
  in.submission = &zip;
  in.track = track;
  run.scenes = EvaluateScenes(in);
  int64_t missing = 0, dropped = 0;
  for (const auto& s : run.scenes) {
    missing += s.failures;
    dropped += static_cast<int64_t>(s.dropped_count);
    for (const auto& d : s.dropped) FREELOC_LOG(DEBUG) << "pose_" << s.name << ".txt " << d;
  }
  if (dropped)
    FREELOC_LOG(WARNING) << submission_path << ": " << dropped
                         << " lines dropped by the official parsing rules (debug logging lists them)";
  if (missing) FREELOC_LOG(WARNING) << submission_path << ": missing pose estimates for " << missing << " frames";
  run.overall = Aggregate(run.scenes);
  for (const auto& s : run.scenes) {
    if (s.estimates() == 0) continue;
    run.per_scene.emplace_back(s.name, Aggregate({s}));
  }
  return run;
}

std::string MarkdownReport(const EvalRun& r) {
  std::ostringstream os;
  const Metrics& m = r.overall;
  os << "## Map-free metrics — " << r.label << "\n\n";
  os << "| metric | value |\n|---|---|\n";
  os << "| Average Median Translation Error | " << F("%.4f", m.avg_median_trans) << " m |\n";
  os << "| Average Median Rotation Error | " << F("%.4f", m.avg_median_rot) << " ° |\n";
  os << "| Average Median Reprojection Error | " << F("%.3f", m.avg_median_vcre) << " px |\n";
  os << "| Precision @ Pose Error < (25.0cm, 5deg) | " << F("%.4f", m.precision_pose) << " |\n";
  os << "| AUC @ Pose Error < (25.0cm, 5deg) | " << F("%.4f", m.auc_pose) << " |\n";
  os << "| Precision @ VCRE < 90px | " << F("%.4f", m.precision_vcre) << " |\n";
  os << "| AUC @ VCRE < 90px | " << F("%.4f", m.auc_vcre) << " |\n";
  os << "| Estimates for % of frames | " << F("%.4f", m.estimates_ratio) << " |\n";
  os << "\n"
     << m.estimates << " estimates, " << m.failures << " failures, " << r.scenes.size() << " scenes ("
     << m.scenes_with_estimates << " with estimates)\n\n";
  os << "| scene | estimates | failures | median t (m) | median R (°) | median VCRE (px) | prec pose | prec VCRE |\n";
  os << "|---|---|---|---|---|---|---|---|\n";
  for (const auto& s : r.scenes) {
    const auto it =
        std::find_if(r.per_scene.begin(), r.per_scene.end(), [&](const auto& p) { return p.first == s.name; });
    os << "| " << s.name << " | " << s.estimates() << " | " << s.failures << " | ";
    if (it == r.per_scene.end()) {
      os << (s.file_present ? "– | – | – | 0 | 0 |" : "no pose file | – | – | 0 | 0 |") << "\n";
      continue;
    }
    const Metrics& p = it->second;
    os << F("%.4f", p.avg_median_trans) << " | " << F("%.3f", p.avg_median_rot) << " | " << F("%.2f", p.avg_median_vcre)
       << " | " << F("%.3f", p.precision_pose) << " | " << F("%.3f", p.precision_vcre) << " |\n";
  }
  return os.str();
}

std::string MarkdownCompare(const std::vector<EvalRun>& runs) {
  std::ostringstream os;
  os << "| metric |";
  for (const auto& r : runs) os << " " << r.label << " |";
  os << "\n|---|";
  for (size_t i = 0; i < runs.size(); ++i) os << "---|";
  os << "\n";
  for (int k = 0; k < 8; ++k) {
    os << "| " << kMetricNames[k] << " |";
    for (const auto& r : runs)
      os << " " << F(k < 2 ? "%.4f" : k == 2 ? "%.3f" : "%.4f", MetricValues(r.overall)[k]) << " |";
    os << "\n";
  }
  os << "| estimates / failures |";
  for (const auto& r : runs) os << " " << r.overall.estimates << " / " << r.overall.failures << " |";
  os << "\n";
  return os.str();
}

std::string JsonReport(const EvalRun& r, int indent) {
  nlohmann::ordered_json j = MetricsJson(r.overall);
  nlohmann::ordered_json per = nlohmann::ordered_json::object();
  for (const auto& s : r.scenes) {
    nlohmann::ordered_json e;
    const auto it =
        std::find_if(r.per_scene.begin(), r.per_scene.end(), [&](const auto& p) { return p.first == s.name; });
    if (it != r.per_scene.end()) e = MetricsJson(it->second);
    e["estimates"] = s.estimates();
    e["failures"] = s.failures;
    e["pose_file"] = s.file_present;
    e["lines_dropped"] = s.dropped_count;
    per[s.name] = e;
  }
  j["per_scene"] = per;
  int64_t dropped = 0, missing_scenes = 0;
  for (const auto& s : r.scenes) {
    dropped += static_cast<int64_t>(s.dropped_count);
    missing_scenes += !s.file_present;
  }
  j["counts"] = {{"scenes", r.scenes.size()},
                 {"scenes_with_estimates", r.overall.scenes_with_estimates},
                 {"scenes_without_pose_file", missing_scenes},
                 {"estimates", r.overall.estimates},
                 {"failures", r.overall.failures},
                 {"frames", r.overall.estimates + r.overall.failures},
                 {"lines_dropped", dropped}};
  return JsonDump(j, indent) + "\n";
}

std::string ErrorsCsv(const EvalRun& r) {
  std::ostringstream os;
  os << "scene,frame,trans_err,rot_err,vcre,confidence,status\n";
  char buf[160];
  for (const auto& s : r.scenes) {
    for (const auto& f : s.frames) {
      if (f.status == "submitted") {
        std::snprintf(buf, sizeof(buf), "%s,%05lld,%.9g,%.9g,%.9g,%.9g,%s\n", s.name.c_str(),
                      static_cast<long long>(f.frame), f.err.trans_err, f.err.rot_err, f.err.vcre, f.confidence,
                      f.status.c_str());
      } else {
        std::snprintf(buf, sizeof(buf), "%s,%05lld,,,,,%s\n", s.name.c_str(), static_cast<long long>(f.frame),
                      f.status.c_str());
      }
      os << buf;
    }
  }
  return os.str();
}

std::string CdfSvg(const std::vector<const EvalRun*>& runs, const std::string& title_in, const std::string& x_label_in,
                   int which, double threshold, double x_max) {
  std::string title = title_in, x_label = x_label_in;
  title = EscapeMarkup(title);
  x_label = EscapeMarkup(x_label);
  const double W = 640, H = 420, L = 70, R = 20, T = 40, B = 60;
  const double pw = W - L - R, ph = H - T - B;
  auto X = [&](double v) { return L + std::min(v, x_max) / x_max * pw; };
  auto Y = [&](double f) { return T + (1.0 - f) * ph; };
  static const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b"};
  std::ostringstream os;
  os << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H << "\" viewBox=\"0 0 " << W
     << " " << H << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
  os << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  os << "<text x=\"" << W / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">" << title << "</text>\n";
  // Grid and ticks.
  for (int i = 0; i <= 5; ++i) {
    const double f = i / 5.0;
    os << "<line x1=\"" << L << "\" y1=\"" << Y(f) << "\" x2=\"" << L + pw << "\" y2=\"" << Y(f)
       << "\" stroke=\"#ddd\"/>\n";
    os << "<text x=\"" << L - 8 << "\" y=\"" << Y(f) + 4 << "\" text-anchor=\"end\">" << F("%.1f", f) << "</text>\n";
    const double xv = x_max * i / 5.0;
    os << "<line x1=\"" << X(xv) << "\" y1=\"" << T << "\" x2=\"" << X(xv) << "\" y2=\"" << T + ph
       << "\" stroke=\"#ddd\"/>\n";
    os << "<text x=\"" << X(xv) << "\" y=\"" << T + ph + 18 << "\" text-anchor=\"middle\">"
       << F(x_max < 10 ? "%.2f" : "%.0f", xv) << "</text>\n";
  }
  os << "<rect x=\"" << L << "\" y=\"" << T << "\" width=\"" << pw << "\" height=\"" << ph
     << "\" fill=\"none\" stroke=\"black\"/>\n";
  os << "<text x=\"" << L + pw / 2 << "\" y=\"" << H - 15 << "\" text-anchor=\"middle\">" << x_label << "</text>\n";
  os << "<text transform=\"translate(18," << T + ph / 2
     << ") rotate(-90)\" text-anchor=\"middle\">fraction of evaluated frames with error ≤ x</text>\n";
  os << "<line x1=\"" << X(threshold) << "\" y1=\"" << T << "\" x2=\"" << X(threshold) << "\" y2=\"" << T + ph
     << "\" stroke=\"#555\" stroke-dasharray=\"5,4\"/>\n";
  os << "<text x=\"" << X(threshold) + 4 << "\" y=\"" << T + 14 << "\" fill=\"#555\">threshold " << F("%g", threshold)
     << "</text>\n";
  for (size_t k = 0; k < runs.size(); ++k) {
    std::vector<double> v;
    int64_t total = 0;
    for (const auto& s : runs[k]->scenes) {
      for (const auto& f : s.frames) {
        if (f.status != "submitted") continue;
        v.push_back(which == 0 ? f.err.trans_err : which == 1 ? f.err.rot_err : f.err.vcre);
      }
    }
    total = runs[k]->overall.estimates + runs[k]->overall.failures;
    std::sort(v.begin(), v.end());
    std::ostringstream pts;
    pts << X(0) << "," << Y(0);
    for (size_t i = 0; i < v.size(); ++i) {
      if (!std::isfinite(v[i])) continue;
      const double f0 = total ? static_cast<double>(i) / total : 0, f1 = total ? static_cast<double>(i + 1) / total : 0;
      pts << " " << X(v[i]) << "," << Y(f0) << " " << X(v[i]) << "," << Y(f1);
    }
    const double fend = total ? static_cast<double>(v.size()) / total : 0;
    pts << " " << X(x_max) << "," << Y(fend);
    const char* c = colours[k % 6];
    os << "<polyline fill=\"none\" stroke=\"" << c << "\" stroke-width=\"2\" points=\"" << pts.str() << "\"/>\n";
    std::string label = runs[k]->label;
    label = EscapeMarkup(label);
    os << "<rect x=\"" << L + pw - 190 << "\" y=\"" << T + ph - 20 - 18 * (runs.size() - 1 - k) - 9
       << "\" width=\"14\" height=\"4\" fill=\"" << c << "\"/>\n";
    os << "<text x=\"" << L + pw - 170 << "\" y=\"" << T + ph - 20 - 18 * (runs.size() - 1 - k) << "\">" << label
       << "</text>\n";
  }
  os << "</svg>\n";
  return os.str();
}

void WriteReportDir(const std::string& dir, const std::vector<const EvalRun*>& runs) {
  FREELOC_CHECK(!runs.empty(), "WriteReportDir: no runs");
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  FREELOC_CHECK(std::filesystem::is_directory(dir),
                dir << ": cannot create the report folder (" << ec.message() << ")");
  const EvalRun& r = *runs.front();
  auto write = [&](const std::string& name, const std::string& text) {
    io::WriteFileAtomic(dir + "/" + name, text.data(), text.size());
  };
  if (runs.size() == 1) {
    write("metrics.json", JsonReport(r));
    write("errors.csv", ErrorsCsv(r));
  } else {
    for (const auto* run : runs) {
      const std::string stem = std::filesystem::path(run->label).stem().string();
      write("metrics_" + stem + ".json", JsonReport(*run));
      write("errors_" + stem + ".csv", ErrorsCsv(*run));
    }
  }
  write("cdf_translation.svg",
        CdfSvg(runs, "Translation error (camera centre)", "translation error [m]", 0, 0.25, 2.0));
  write("cdf_rotation.svg", CdfSvg(runs, "Rotation error", "rotation error [deg]", 1, 5.0, 45.0));
  write("cdf_vcre.svg", CdfSvg(runs, "Virtual correspondence reprojection error (VCRE)", "VCRE [px]", 2, 90.0, 300.0));
}

}  // namespace freeloc::eval

#include "freeloc/pipeline/run_fields.h"

namespace freeloc::pipeline {

namespace {

// The report's two counts live in RunSpec::report_options.
FamilyRow<RunSpec> ReportCount(const char* name, const char* flag, int eval::ReportOptions::*member, const char* help) {
  FamilyRow<RunSpec> r;
  r.field = {name, flag, FieldType::kInteger, "", help, 0, 1e6};
  r.get = [member](const RunSpec& s) { return std::to_string(s.report_options.*member); };
  r.set = [member, f = r.field](RunSpec* s, const std::string& v) {
    CheckFieldText(f, v);
    s->report_options.*member = static_cast<int>(TextToNumber(v));
  };
  return r;
}

FamilyRow<RunSpec> ShardRow() {
  FamilyRow<RunSpec> r;
  r.field = {"shard", "--shard", FieldType::kText, "",
             "i/n: only every n-th scene starting at the i-th (1 ≤ i ≤ n); join the shards with freeloc merge"};
  r.get = [](const RunSpec& s) { return s.shard.ToString(); };
  r.set = [](RunSpec* s, const std::string& v) { s->shard = v.empty() ? Shard() : Shard::FromString(v); };
  return r;
}

const std::vector<FamilyRow<RunSpec>>& Rows() {
  static const std::vector<FamilyRow<RunSpec>> rows = {
      Row("data", "--data", &RunSpec::data, "dataset root (holding val/ test/) or a split folder"),
      Row("split", "--split", &RunSpec::split, "split folder"),
      Row("scenes", "--scenes", &RunSpec::scenes, "comma-separated scene names (default: all)"),
      Row("out", "--out", &RunSpec::out,
          "submission ZIP (written atomically; <out>.json beside it holds the provenance)"),
      Row("log", "--log", &RunSpec::log, "JSON-lines log: a header record, then one record per query"),
      Row("save_matches", "--save-matches", &RunSpec::save_matches,
          "folder: each query's correspondences as <scene>/seq1/frame_XXXXX.matches.txt (the input of freeloc pose)"),
      Row("report", "--report", &RunSpec::report,
          "folder: an HTML report of the run (index.html: metrics, every query, failures, match overlays of the "
          "worst queries; docs/report.md)"),
      ReportCount("report_worst", "--report-worst", &eval::ReportOptions::worst,
                  "queries with the largest errors shown in detail"),
      ReportCount("report_per_scene", "--report-per-scene", &eval::ReportOptions::per_scene,
                  "first queries of each scene shown in detail"),
      Row("resume", "--resume", &RunSpec::resume,
          "continue an interrupted run from <out>.progress.jsonl (same options), skipping finished scenes"),
      ShardRow(),
  };
  return rows;
}

}  // namespace

const OptionFamily& RunFamily() {
  static const OptionFamily family =
      FamilyOf("run", "freeloc run flags, freeloc.run keywords, the run fields of an options file", Rows());
  return family;
}

void SetRunField(RunSpec* spec, const std::string& name, const std::string& text) {
  FindRow(Rows(), "run", name).set(spec, text);
}

std::string GetRunField(const RunSpec& spec, const std::string& name) { return FindRow(Rows(), "run", name).get(spec); }

}  // namespace freeloc::pipeline

// `run --report DIR` (eval/run_report.h): what the run controller records per query for the report, and the report
// written at the end. Each process renders the detail images of its own candidates as their queries finish (the
// first queries of each scene, the failures, the worst so far — evicted ones are deleted), so the report never
// re-runs a network and the folder stays bounded; at the end rank 0 keeps the final selection and writes
// index.html with the metrics of the submission.
#pragma once

#include <map>
#include <set>
#include <string>
#include <vector>

#include "freeloc/eval/run_report.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/pipeline/query_result.h"
#include "freeloc/pipeline/relocalizer.h"

namespace freeloc::pipeline {

class ReportRecorder {
 public:
  ReportRecorder(std::string dir, eval::ReportOptions options);
  // After each query of `scene` (its correspondences `c`; the depths from `reloc`).
  void Consider(const io::MapfreeScene& scene, const QueryResult& r, const matching::Correspondences& c,
                const Relocalizer& reloc);
  // Rank 0, after the submission is written: the final selection, then index.html.
  void Write(const std::string& split_dir, const std::vector<std::string>& scenes,
             const std::map<std::string, io::MapfreeScene>& loaded,
             const std::map<std::string, std::vector<QueryResult>>& results, const std::string& submission) const;

 private:
  std::string dir_;
  eval::ReportOptions o_;
  std::map<std::string, int> per_scene_;  // queries rendered as the first of their scene
  int failures_ = 0;
  std::multimap<double, std::string> worst_;  // badness → file, the worst kept so far
  std::set<std::string> pinned_;              // files kept for the per-scene and failure samples
  std::string ref_scene_;                     // the scene whose reference image `ref_` holds
  Image ref_;
};

// The report's view of one query (errors from the scene's ground truth when it has some).
eval::ReportQuery ToReportQuery(const io::MapfreeScene& scene, const QueryResult& r);
// The detail image's file name of a query.
std::string VisualName(const std::string& scene, const std::string& frame);

// `relocalize --report DIR`: the report of one pair — `dir`/index.html with the query's row, its detail image
// (matches, depth maps) and its 3D view, as `run --report` shows each query.
// `query_name` names the query's row (its file name).
void WritePairReport(const std::string& dir, const std::string& title, const std::string& query_name, const Image& ref,
                     const Image& query, const QueryResult& r, const matching::Correspondences& c,
                     const Relocalizer& reloc);

}  // namespace freeloc::pipeline

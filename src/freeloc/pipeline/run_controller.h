// The run controller (docs/architecture.md §3.3): every query of every scene of a map-free split into one submission.
// It owns the long-running work — scenes read and checked before any work, networks loaded before the first scene, the
// journal (`<out>.progress.jsonl`: a header, then one line per finished scene, fsync'ed) and --resume, shards,
// per-query and per-scene error isolation, the submission (atomic), the JSON-lines log and the provenance sidecar
// `<out>.json`. `freeloc run` and `freeloc demo` only parse arguments, call ExecuteRun and print.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "freeloc/eval/run_report.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/pipeline/options.h"
#include "freeloc/pipeline/query_result.h"
#include "freeloc/pipeline/relocalizer.h"

namespace freeloc::pipeline {

// Shard i of n takes every n-th scene of the sorted list, starting at the i-th (1 ≤ i ≤ n).
struct Shard {
  int index = 0, count = 0;                          // count 0: the whole split
  static Shard FromString(const std::string& text);  // "i/n"; throws naming the field "shard"
  std::string ToString() const;                      // "i/n", or "" for the whole split
  bool whole() const { return count == 0; }
  std::vector<std::string> Select(const std::vector<std::string>& scenes) const;
};

class RunComm;

struct RunSpec {
  std::string data;  // dataset root (holding val/, test/) or a split folder
  std::string split = "val";
  std::vector<std::string> scenes;  // empty: every scene of the split
  std::string out;                  // submission ZIP
  std::string log;                  // JSON-lines log (optional): a header line, then one record per query
  std::string save_matches;         // folder (optional): <scene>/<frame>.matches.txt per query, full precision
  std::string report;               // folder (optional): the HTML report of the run (eval/run_report.h)
  eval::ReportOptions report_options;
  bool resume = false;  // continue from <out>.progress.jsonl
  Shard shard;
  bool progress_bar = true;  // one bar over the queries on stderr (when it is a terminal)
  // Called after each query (and once for each resumed scene) with the queries done and the total.
  std::function<void(int64_t done, int64_t total)> on_progress;
  // Called on each rank of a multi-process run once its scenes are assigned (tests/mpi/fault_run.cc kills a rank
  // there, as a crashed node would).
  std::function<void(const RunComm& comm)> on_assigned;
  void Validate() const;  // throws naming the field
};

struct RunResult {
  std::string split_dir;
  std::vector<std::string> scenes;                                    // the scenes run (this shard's), sorted
  std::map<std::string, io::MapfreeScene> loaded;                     // … as read (cameras, ground truth)
  std::map<std::string, std::vector<QueryResult>> results;            // per scene, queries in poses.txt order
  size_t queries = 0, solved = 0, submitted = 0, resumed_scenes = 0;  // query_result.h's words
  // Rank 0, after the outputs are written: how many queries ended with each status, and the queries that failed on
  // an input error (status error: an unreadable or damaged image, depth map or reference) with the first messages.
  std::map<std::string, size_t> statuses;
  size_t input_errors = 0;
  std::vector<std::string> input_error_messages;  // "<scene>/<frame>: <message>", at most 5
};

// Makes the relocalizer of a run (tests and users plug their own stages here); default: Relocalizer(options).
using RelocalizerFactory = std::function<std::unique_ptr<Relocalizer>(const PipelineOptions&)>;

// Runs `spec` with `options` (validated; models found beforehand by the caller, FindModels). Throws freeloc::Error
// before any work for a bad split, scene, depth suffix, weights file or journal; per-query and per-scene failures
// are results. Nothing is written unless the run finishes (the journal excepted).
// With `comm` of more than one rank (run_comm.h: MPI), the scenes are split over the ranks and rank 0 writes the
// outputs (the same bytes as one process); the other ranks return their own scenes' results only.
RunResult ExecuteRun(const RunSpec& spec, const PipelineOptions& options, const RelocalizerFactory& factory = nullptr,
                     RunComm* comm = nullptr);

// The split folder under `data` (or `data` itself) and the scenes to process: all of them, or `only` (each must
// exist). Throws freeloc::Error naming what is missing.
std::vector<std::string> ResolveScenes(const std::string& data, const std::string& split,
                                       const std::vector<std::string>& only, std::string* split_dir);

}  // namespace freeloc::pipeline

// The one JSON record format of freeloc's outputs (docs/formats.md): a query's result (the `run` log and journal,
// `relocalize --json`, `pose --json`, Python's PoseResult.as_dict), the resolved options (every field, by the names
// of OptionFields), and a run's header (provenance: version, options, data, split, shard). Records are strings of
// JSON so this header stays light; the .cc uses nlohmann::json.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "freeloc/pipeline/options.h"
#include "freeloc/pipeline/query_result.h"

namespace freeloc::pipeline {

// {"matcher": "sift", "depth": "provided:sensor", …, "threads": 0} — every field, numbers as numbers.
std::string OptionsJson(const PipelineOptions& options);
// The inverse: fields absent from `json` keep their defaults; an unknown field or bad value throws naming it.
PipelineOptions OptionsFromJson(const std::string& json);

// {"scene", "frame", "status", ["message"], "ok", "metric", "qvec", "tvec", "confidence", "matches", "inliers",
//  …, "solve_ms"[, "options"]}: `scene` and `frame` only when not empty, `options` when given. `indent` < 0: one line.
std::string QueryRecordJson(const std::string& scene, const QueryResult& r, const PipelineOptions* options = nullptr,
                            int indent = -1);
// Parses a record written by QueryRecordJson (and the log format of freeloc 0.1, whose status may read
// "error: <message>"). Throws freeloc::Error naming what is missing.
QueryResult QueryResultFromJson(const std::string& json, std::string* scene = nullptr);

// Provenance of a run: the first line of its log and journal, and the sidecar `<submission>.json`.
struct RunHeader {
  PipelineOptions options;
  std::string data, split, shard;  // shard "i/n", or "" for the whole split
  std::vector<std::string> scenes;
};
// {"freeloc_run": 1, "freeloc_version", "options": {…}, "data", "split", "shard", "scenes"}; `extra` (a JSON object
// text, optional) is merged in (e.g. the sidecar's "summary").
std::string RunHeaderJson(const RunHeader& h, const std::string& extra = "");
// Whether a header line (RunHeaderJson) was written with options that give the same results as `options`
// (every field but `threads`); `why` receives the first differing field.
bool SameResultOptions(const std::string& header_json, const PipelineOptions& options, std::string* why);

// An options file (`--options FILE`): a run's provenance read back — the sidecar `<submission>.json`, a log (its
// first line, the run header), a `relocalize --json`/`pose --json` record — or a hand-written object. `options`:
// the pipeline options by name (the file's "options" object, or the object itself when it has none); `run`: the run
// fields at the top (data, split, scenes, shard, …), as text (a list comma-joined). Throws naming the file.
struct OptionsFile {
  std::map<std::string, std::string> options;  // name → text (SetOption's form)
  std::map<std::string, std::string> run;      // run field → text (SetRunField's form), names as written
};
OptionsFile ReadOptionsFile(const std::string& path);

}  // namespace freeloc::pipeline

// `freeloc relocalize`: the pose of one query image relative to one reference image, through the pipeline's
// Relocalizer (the same stages as `freeloc run`).
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/core/progress.h"
#include "freeloc/core/timing.h"
#include "freeloc/inputs/intrinsics.h"
#include "freeloc/io/correspondence_file.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/pipeline/record.h"
#include "freeloc/pipeline/relocalizer.h"
#include "freeloc/pipeline/report_recorder.h"

namespace freeloc::cli {

namespace {

struct RelocArgs {
  PipelineArgs pipeline;
  std::string ref, query, ref_k, query_k, intrinsics, ref_depth, query_depth, ref_masks, query_masks, save_matches;
  std::string report;  // --report DIR
  bool json = false;
};

// The camera of `image` in an intrinsics file (map-free `intrinsics.txt` lines: path fx fy cx cy W H): the line
// whose path is the image's path, a suffix of it, or has its file name.
Camera CameraFromFile(const std::string& file, const std::string& image) {
  const std::vector<io::MapfreeFrame> frames = io::ReadIntrinsicsFile(file);
  const std::string base = std::filesystem::path(image).filename().string();
  const io::MapfreeFrame* by_name = nullptr;
  for (const auto& f : frames) {
    if (image == f.name || (image.size() > f.name.size() &&
                            image.compare(image.size() - f.name.size() - 1, f.name.size() + 1, "/" + f.name) == 0))
      return f.camera;
    if (!by_name && std::filesystem::path(f.name).filename().string() == base) by_name = &f;
  }
  FREELOC_CHECK(by_name != nullptr, file << ": no line for " << image
                                         << "; each line is 'path fx fy cx cy width height' with the image's path "
                                            "or file name");
  return by_name->camera;
}

// One photo with the intrinsics freeloc's order gives it (inputs/intrinsics.h): --<frame>-intrinsics or
// --intrinsics FILE > EXIF > the pointmap's focal > a one-line error naming the flags.
struct Photo {
  Image image;
  inputs::IntrinsicsChoice intrinsics;
};

Photo LoadPhoto(const RelocArgs& a, const pipeline::PipelineOptions& o, bool ref) {
  const std::string& path = ref ? a.ref : a.query;
  const std::string& flag_value = ref ? a.ref_k : a.query_k;
  const std::string flag = ref ? "--ref-intrinsics" : "--query-intrinsics";
  Camera given;
  pipeline::IntrinsicsSource source = pipeline::IntrinsicsSource::kGiven;
  if (!flag_value.empty()) {
    given = Camera::FromString(flag_value, flag);
  } else if (!a.intrinsics.empty()) {
    given = CameraFromFile(a.intrinsics, path);
    source = pipeline::IntrinsicsSource::kFile;
  }
  const bool have = !flag_value.empty() || !a.intrinsics.empty();
  Photo p;
  io::ExifInfo exif;
  p.image = io::ReadImage(path, &exif, o.WorkingMaxSide());
  p.intrinsics = inputs::ChooseIntrinsics(have ? &given : nullptr, source, exif, p.image, o.UsesPointmapModel(), path);
  FREELOC_CHECK(p.intrinsics.source != pipeline::IntrinsicsSource::kNone,
                path << ": no intrinsics (its EXIF: " << p.intrinsics.why << "); give " << flag
                     << " fx,fy,cx,cy or --intrinsics FILE, or use a dust3r or mast3r preset (they estimate the focal "
                        "from the pointmap)");
  return p;
}

pipeline::PipelineOptions Options(const RelocArgs& a, const GlobalOptions& g) {
  return ResolvePipelineArgs(a.pipeline, g, "sift-essential", [&](pipeline::PipelineOptions* o) {
    // No depth files and no --depth: the provided-depth presets answer with a unit translation.
    if (a.ref_depth.empty() && a.query_depth.empty() &&
        (a.pipeline.values.count("depth") == 0 || a.pipeline.values.at("depth").empty()) && o->UsesProvidedDepth())
      o->depth.kind = pipeline::DepthKind::kNone;
    FREELOC_OPTION_CHECK("matcher", !o->UsesPrecomputed(),
                         ": relocalize works on images: use sift, dust3r, dust3r+instances, mast3r or mast3r+instances "
                         "(precomputed correspondences go to freeloc pose)");
    ApplyMaskArgs(o, !a.ref_masks.empty(), !a.query_masks.empty());
  });
}

// "fx 535.4 fy 539.2 cx 320.1 cy 247.6 (exif; EXIF orientation 6: rotated 90° clockwise)"
std::string IntrinsicsText(const pipeline::FrameIntrinsics& f) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), "fx %.2f fy %.2f cx %.2f cy %.2f (%s", f.camera.fx, f.camera.fy, f.camera.cx,
                f.camera.cy, ToString(f.source).c_str());
  std::string s = buf;
  if (f.pointmap_focal > 0 && f.source != pipeline::IntrinsicsSource::kPointmap) {
    std::snprintf(buf, sizeof(buf), "; pointmap focal %.1f", f.pointmap_focal);
    s += buf;
  }
  if (f.orientation >= 2)
    s += "; EXIF orientation " + std::to_string(f.orientation) + ": " + io::OrientationText(f.orientation);
  return s + ")";
}

void Print(const pipeline::QueryResult& q, const pipeline::PipelineOptions& o, bool json) {
  if (json) {
    std::printf("%s\n", pipeline::QueryRecordJson("", q, &o, 2).c_str());
    return;
  }
  const auto qv = q.query_from_ref.QuaternionWxyz();
  const auto& t = q.query_from_ref.translation;
  std::printf(
      "%s\nstatus:      %s\nqvec (wxyz): %.9f %.9f %.9f %.9f\ntvec:        %.6f %.6f %.6f %s\n"
      "confidence:  %.6g\nmatches:     %d (%d inliers)\ninstances:   %d of %d used\n"
      "times:       decode %.0f ms, prepare %.0f ms, depth %.0f ms, match %.0f ms, instances %.0f ms, solve %.0f ms\n"
      "intrinsics:  ref %s\n             query %s\n",
      o.Summary().c_str(), q.StatusText().c_str(), qv[0], qv[1], qv[2], qv[3], t.x(), t.y(), t.z(),
      q.metric()  ? "(metres)"
      : q.prior() ? "(the prior pose, submitted with confidence 0: not solved)"
      : q.weak()  ? "(weak support: a low-confidence answer, ranked below every ok one)"
                  : "(unit norm: no depth)",
      q.confidence, q.matches, q.inliers, q.instances_used, q.instances, q.timings.decode_ms, q.timings.prepare_ms,
      q.timings.depth_ms, q.timings.match_ms, q.timings.instance_ms, q.timings.solve_ms,
      IntrinsicsText(q.ref_intrinsics).c_str(), IntrinsicsText(q.query_intrinsics).c_str());
  for (const std::string& note : q.input_notes) std::printf("inputs:      %s\n", note.c_str());
}

int RunRelocalize(const RelocArgs& a, const GlobalOptions& g) {
  const pipeline::PipelineOptions o = Options(a, g);
  FREELOC_CHECK(a.intrinsics.empty() || (a.ref_k.empty() && a.query_k.empty()),
                "give --ref-intrinsics/--query-intrinsics (fx,fy,cx,cy) or --intrinsics FILE, not both");
  // A terminal shows what runs for a query over 2 s; --verbose logs each stage as it starts.
  StageTicker ticker("relocalize");
  const auto t0 = std::chrono::steady_clock::now();
  SetStage("decoding the photos");
  const Photo ref_photo = LoadPhoto(a, o, true), query_photo = LoadPhoto(a, o, false);
  const Image &ref = ref_photo.image, &query = query_photo.image;
  std::vector<uint16_t> ref_labels, query_labels;
  pipeline::FrameInputs in_ref, in_query;
  const Camera kr = pipeline::ApplyIntrinsics(ref_photo.intrinsics, &in_ref);
  const Camera kq = pipeline::ApplyIntrinsics(query_photo.intrinsics, &in_query);
  if (!a.ref_depth.empty()) in_ref.depth = io::ReadDepthPng(a.ref_depth);
  if (!a.query_depth.empty()) in_query.depth = io::ReadDepthPng(a.query_depth);
  if (!a.ref_masks.empty())
    in_ref.instance_labels = &(ref_labels = ReadLabels(a.ref_masks, ref.PhotoWidth(), ref.PhotoHeight()));
  if (!a.query_masks.empty())
    in_query.instance_labels = &(query_labels = ReadLabels(a.query_masks, query.PhotoWidth(), query.PhotoHeight()));
  const double decode_ms = MsSince(t0);
  const auto t1 = std::chrono::steady_clock::now();
  pipeline::Relocalizer reloc(o, pipeline::Relocalizer::kOptionsValidated);  // Options() validated them
  reloc.SetReference(ref, kr, std::move(in_ref));
  const double reference_ms = MsSince(t1);
  matching::Correspondences c;
  pipeline::QueryResult q = reloc.Relocalize(query, kq, std::move(in_query), &c);
  ticker.Stop();
  // The record accounts for the whole command: the decoding, and with the preparation the start-up, the stages'
  // set-up and the reference's own work.
  q.timings.decode_ms = decode_ms;
  q.timings.prepare_ms += reference_ms + std::chrono::duration<double, std::milli>(t0 - ProcessStart()).count();
  if (!a.save_matches.empty()) io::WriteCorrespondenceFile(a.save_matches, c.Rows());
  if (!a.report.empty()) {
    pipeline::WritePairReport(a.report,
                              "freeloc relocalize — " + std::filesystem::path(a.query).filename().string() + " from " +
                                  std::filesystem::path(a.ref).filename().string(),
                              std::filesystem::path(a.query).filename().string(), ref, query, q, c, reloc);
    FREELOC_LOG(INFO) << "report written to " << a.report << "/index.html";
  }
  Print(q, o, a.json);
  return q.ok() ? 0 : 1;
}

}  // namespace

void RegisterRelocalize(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto a = std::make_shared<RelocArgs>();
  auto* rs = app.add_subcommand("relocalize", "Pose of one query image relative to one reference image");
  rs->add_option("--ref", a->ref, "reference image")->required();
  rs->add_option("--query", a->query, "query image")->required();
  rs->add_option("--ref-intrinsics", a->ref_k,
                 "fx,fy,cx,cy; without it: the photo's EXIF focal, else the pointmap's (dust3r/mast3r presets)");
  rs->add_option("--query-intrinsics", a->query_k, "fx,fy,cx,cy (the same order of sources)");
  rs->add_option("--intrinsics", a->intrinsics,
                 "instead of the two above: a file of 'path fx fy cx cy W H' lines (map-free intrinsics.txt)");
  rs->add_option("--save-matches", a->save_matches, "write the correspondences (x_ref y_ref x_query y_query per line)");
  rs->add_option("--report", a->report,
                 "write a report of the pair to this folder (index.html: the matches, the depth maps, the 3D view; "
                 "docs/report.md)");
  rs->add_option("--ref-depth", a->ref_depth, "reference depth PNG (uint16 mm)");
  rs->add_option("--query-depth", a->query_depth, "query depth PNG (uint16 mm)");
  rs->add_option(
      "--ref-masks", a->ref_masks,
      "reference instance label PNG (0 = background, k = instance k) for dust3r+instances or mast3r+instances");
  rs->add_option("--query-masks", a->query_masks, "query instance label PNG (same labels; else SegGPT propagates)");
  rs->add_flag("--json", a->json, "one JSON record (docs/formats.md) with the resolved options");
  AddPipelineArgs(rs, &a->pipeline, "sift-essential");
  rs->callback([a, run, &global] { *run = [a, &global] { return RunRelocalize(*a, global); }; });
}

}  // namespace freeloc::cli

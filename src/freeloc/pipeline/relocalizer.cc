#include "freeloc/pipeline/relocalizer.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/core/progress.h"
#include "freeloc/core/timing.h"
#include "freeloc/inputs/input_checks.h"
#include "freeloc/inputs/model_files.h"
#include "freeloc/inputs/working_frame.h"

namespace freeloc::pipeline {

void FindModels(PipelineOptions* o) {
  const auto dirs = inputs::ModelDirs(o->models.models_dir);
  if (o->UsesDust3r() && o->models.dust3r_model.empty())
    o->models.dust3r_model = inputs::FindModel(inputs::Network::kDust3r, dirs);
  if (o->UsesMast3r() && o->models.mast3r_model.empty())
    o->models.mast3r_model = inputs::FindModel(inputs::Network::kMast3r, dirs);
  if (o->UsesSegGpt() && o->models.seggpt_model.empty())
    o->models.seggpt_model = inputs::FindModel(inputs::Network::kSegGpt, dirs);
  if (o->UsesMetric3d() && o->models.metric3d_model.empty())
    o->models.metric3d_model = inputs::FindModel(inputs::Network::kMetric3d, dirs);
}

void LoadModels(const PipelineOptions& o) {
  // Building the stages loads their networks into the per-process caches.
  MakeMatcher(o);
  MakeDepthEstimator(o);
}

// ---------------------------------------------------------------------------------------------------------------
// The relocalizer: the stages, the reference's share once, the query's share per query.

struct Relocalizer::Impl {
  PipelineOptions o;
  std::unique_ptr<Matcher> matcher;
  std::unique_ptr<DepthEstimator> depth;
  std::unique_ptr<PoseSolver> solver;
  CacheStats stats;
  Camera k_ref;
  FrameIntrinsics ref_intrinsics;
  inputs::InputNotes ref_notes;  // what the input checks did to the reference's inputs
  inputs::PixelScale ref_scale;  // the reference's photo pixels per working pixel
  std::string ref_depth_name;    // the reference's depth source (or the file expected), for messages
  DepthMap d_ref, d_query;
  bool have_ref = false;
  void UpdateStats() {
    matcher->AddStats(&stats);
    depth->AddStats(&stats);
  }
};

Relocalizer::Relocalizer(const PipelineOptions& options, OptionsValidated)
    : Relocalizer(options, MakeMatcher(options), MakeDepthEstimator(options), MakePoseSolver(options)) {}

Relocalizer::Relocalizer(const PipelineOptions& options)
    : Relocalizer((options.Validate(), options), kOptionsValidated) {}

Relocalizer::Relocalizer(const PipelineOptions& options, std::unique_ptr<Matcher> matcher,
                         std::unique_ptr<DepthEstimator> depth, std::unique_ptr<PoseSolver> solver)
    : impl_(std::make_unique<Impl>()) {
  FREELOC_CHECK(matcher && depth && solver, "Relocalizer: every stage must be given");
  impl_->o = options;
  impl_->matcher = std::move(matcher);
  impl_->depth = std::move(depth);
  impl_->solver = std::move(solver);
}

Relocalizer::~Relocalizer() = default;
const CacheStats& Relocalizer::stats() const { return impl_->stats; }
const PipelineOptions& Relocalizer::options() const { return impl_->o; }
const DepthMap& Relocalizer::reference_depth() const { return impl_->d_ref; }
const FrameIntrinsics& Relocalizer::reference_intrinsics() const { return impl_->ref_intrinsics; }
const DepthMap& Relocalizer::last_query_depth() const { return impl_->d_query; }

namespace {

bool IsZero(const Camera& c) { return c.fx == 0 && c.fy == 0 && c.cx == 0 && c.cy == 0; }

// Intrinsics handed in (flags, Python, an intrinsics file) must fit the image (input_checks.h): a focal length of
// 1e308, normalised or reordered values are mistakes, not a camera. EXIF and pointmap intrinsics are checked where
// they are made.
void CheckCameraFitsImage(const Camera& camera, const FrameInputs& in, const inputs::WorkingFrame& wf,
                          const InputOptions& o, const char* what, inputs::InputNotes* notes) {
  // No image, or no intrinsics at all (a default Camera: `freeloc match`, whose matchers need none).
  if (wf.image().empty() || IsZero(camera)) return;
  if (in.intrinsics_source != IntrinsicsSource::kGiven && in.intrinsics_source != IntrinsicsSource::kFile) return;
  inputs::CheckIntrinsics(camera, wf.photo_width(), wf.photo_height(), o, what, notes);
}

// The frame's provided depth through the input rule when the depth stage reads it (a map the stages ignore is not
// judged), at the working size.
DepthMap CheckedDepth(DepthMap d, const inputs::WorkingFrame& wf, const PipelineOptions& o, const char* frame,
                      inputs::InputNotes* notes) {
  if (!o.UsesProvidedDepth()) return d;
  return inputs::CheckProvidedDepth(std::move(d), wf.photo_width(), wf.photo_height(), wf.image().width,
                                    wf.image().height, o.inputs, frame, notes);
}

// Intrinsics resolved in working pixels, as reported: in the photo's own pixels (the camera handed in as it was).
FrameIntrinsics InPhotoPixels(FrameIntrinsics fi, const Camera& given, const inputs::WorkingFrame& wf) {
  if (!wf.scaled()) return fi;
  fi.camera = fi.source == IntrinsicsSource::kPointmap ? wf.ToPhoto(fi.camera) : given;
  fi.pointmap_focal *= wf.scale().sx;
  return fi;
}

// The frame's inputs in working pixels: its labels and handed-in correspondences (kept alive in `labels`, `rows`).
void InputsToWorking(const inputs::WorkingFrame& wf, const inputs::PixelScale* ref, FrameInputs* in,
                     std::vector<uint16_t>* labels, std::vector<Eigen::Vector4d>* rows) {
  if (in->instance_labels && wf.scaled()) in->instance_labels = &(*labels = wf.ToWorking(*in->instance_labels));
  if (ref && in->correspondences && (wf.scaled() || ref->scaled()))
    in->correspondences = &(*rows = wf.ToWorking(*in->correspondences, *ref));
}

// A kNoDepth query's message: which map is missing and where it was looked for.
std::string NoDepthMessage(bool ref_missing, const std::string& ref_source, bool query_missing,
                           const std::string& query_source, const PipelineOptions& o) {
  std::string m;
  const auto one = [&](const char* frame, const std::string& source) {
    m += (m.empty() ? "" : "; ") + std::string("no depth map for the ") + frame +
         (source.empty() ? "" : " (looked for " + source + ")");
  };
  if (ref_missing) one("reference", ref_source);
  if (query_missing) one("query", query_source);
  return m + "; depth " + o.depth.ToString() + " needs one for each frame (or use depth none for a unit translation)";
}

// The input checks' notes onto an answer: listed with it, its confidence (and predicted error) scaled.
void ApplyInputNotes(const inputs::InputNotes& notes, QueryResult* r) {
  r->input_notes = notes.notes;
  if (notes.confidence_factor == 1 || r->confidence <= 0) return;
  r->confidence *= notes.confidence_factor;
  r->predicted_translation_m /= notes.confidence_factor;
  r->predicted_rotation_deg /= notes.confidence_factor;
}

// A camera of focal `f` with the principal point at the centre of `image` (pixel centres at integers).
Camera CentredCamera(double f, const Image& image) {
  Camera k;
  k.fx = k.fy = f;
  k.cx = (image.width - 1) / 2.0;
  k.cy = (image.height - 1) / 2.0;
  k.width = image.width;
  k.height = image.height;
  return k;
}

// The frame's intrinsics: the camera handed in (checked against the pointmap's focal when `focal` can give one and
// the check is on), or — the caller asked for kPointmap — the pointmap's focal at the image centre.
FrameIntrinsics ResolveIntrinsics(const Camera& camera, const FrameInputs& in, const Image& image,
                                  const PipelineOptions& o, const std::function<double()>& focal, const char* frame) {
  FrameIntrinsics fi;
  fi.orientation = in.orientation;
  fi.source = in.intrinsics_source;
  fi.camera = camera;
  if (in.intrinsics_source == IntrinsicsSource::kPointmap) {
    const double f = o.UsesPointmapModel() ? focal() : 0;
    FREELOC_CHECK(f > 0 || !o.UsesPointmapModel(),
                  frame << ": no intrinsics were given and its pointmap gives no focal length (too few points in front "
                           "of the camera); give its fx, fy, cx, cy or use a photo whose EXIF has its focal length");
    FREELOC_CHECK(f > 0, frame << ": no intrinsics were given and the matcher " << o.matcher.ToString()
                               << " has no pointmap; give its fx, fy, cx, cy, use a photo whose EXIF has its focal "
                                  "length, or a DUSt3R/MASt3R matcher (they estimate the focal from the pointmap)");
    fi.camera = CentredCamera(f, image);
    fi.pointmap_focal = f;
    return fi;
  }
  if (o.pointmap.check_intrinsics && o.UsesPointmapModel() && !IsZero(camera)) {
    fi.pointmap_focal = focal();
    const double given = std::sqrt(camera.fx * camera.fy);
    if (fi.pointmap_focal > 0 && std::abs(given / fi.pointmap_focal - 1) > 0.05)
      FREELOC_LOG(WARNING) << frame << " intrinsics (" << ToString(fi.source) << "): the focal length " << given
                           << " px differs from the pointmap's estimate " << fi.pointmap_focal << " px by "
                           << std::lround(100 * std::abs(given / fi.pointmap_focal - 1))
                           << " %; a wrong calibration gives a wrong pose — check it (a resized or rotated photo "
                              "keeps its old intrinsics)";
  }
  return fi;
}

}  // namespace

void Relocalizer::SetReference(const Image& image, const Camera& camera, FrameInputs in) {
  Impl& m = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  m.have_ref = false;
  m.ref_notes = inputs::InputNotes();
  m.ref_depth_name = in.depth.source;
  SetStage("reference: preparing");
  const inputs::WorkingFrame wf(image, m.o.WorkingMaxSide());  // the stages keep what they need of the reference
  m.ref_scale = wf.scale();
  CheckCameraFitsImage(camera, in, wf, m.o.inputs, "reference intrinsics", &m.ref_notes);
  in.depth = CheckedDepth(std::move(in.depth), wf, m.o, "reference depth", &m.ref_notes);
  std::vector<uint16_t> labels;
  InputsToWorking(wf, nullptr, &in, &labels, nullptr);
  const Camera k_work = wf.ToWorking(camera);
  SetStage("reference: features or encoding");
  m.matcher->SetReference(wf.image(), k_work, in.instance_labels);
  const FrameIntrinsics fi = ResolveIntrinsics(
      k_work, in, wf.image(), m.o, [&] { return m.matcher->ReferenceFocal(); }, "reference");
  m.k_ref = fi.camera;
  m.ref_intrinsics = InPhotoPixels(fi, camera, wf);
  SetStage("reference: depth");
  m.d_ref = m.depth->Depth(wf.image(), m.k_ref, std::move(in.depth));
  m.stats.reference_ms = MsSince(t0);
  m.UpdateStats();
  m.have_ref = true;
}

matching::Correspondences Relocalizer::Match(const Image& image, const Camera& camera, const FrameInputs& in,
                                             QueryResult* r) {
  FREELOC_CHECK(impl_->have_ref, "Relocalizer::Match before SetReference");
  const inputs::WorkingFrame wf(image, impl_->o.WorkingMaxSide());
  FrameInputs work = in;
  std::vector<uint16_t> labels;
  std::vector<Eigen::Vector4d> rows;
  InputsToWorking(wf, &impl_->ref_scale, &work, &labels, &rows);
  matching::Correspondences c = impl_->matcher->Match(wf.image(), wf.ToWorking(camera), work, r);
  wf.ToPhoto(&c, impl_->ref_scale);
  impl_->UpdateStats();
  return c;
}

void AnswerUnsolved(const PipelineOptions& o, QueryResult* r) {
  const Rigid3d& p = r->query_from_ref;
  if (!p.translation.allFinite() || !p.rotation.coeffs().allFinite() || !std::isfinite(r->confidence)) {
    // Never a pose the submission cannot hold (it would end the whole run): this query fails alone, saying why.
    r->status = QueryStatus::kError;
    r->message = "the answer is not finite (an input far outside its range, such as a tracking pose of 1e308 m)" +
                 (r->message.empty() ? std::string() : "; " + r->message);
    r->query_from_ref = Rigid3d();
    r->confidence = 0;
  }
  if (r->ok() || !o.solve.always_answer) return;
  r->submitted_unsolved = true;
  if (r->weak()) return;          // its own pose, with its (low) confidence
  r->query_from_ref = Rigid3d();  // the prior: the reference camera's pose
  r->confidence = 0;
  r->predicted_translation_m = r->predicted_rotation_deg = 0;
}

QueryResult Relocalizer::Relocalize(const Image& image, const Camera& camera, FrameInputs in,
                                    matching::Correspondences* matches) {
  QueryResult r = Solve(image, camera, std::move(in), matches);
  AnswerUnsolved(impl_->o, &r);
  return r;
}

QueryResult Relocalizer::Solve(const Image& image, const Camera& camera, FrameInputs in,
                               matching::Correspondences* matches) {
  Impl& m = *impl_;
  FREELOC_CHECK(m.have_ref, "Relocalizer::Relocalize before SetReference");
  QueryResult r;
  const auto tp = std::chrono::steady_clock::now();
  SetStage("query: preparing");
  inputs::InputNotes notes = m.ref_notes;
  const inputs::WorkingFrame wf(image, m.o.WorkingMaxSide());
  CheckCameraFitsImage(camera, in, wf, m.o.inputs, "query intrinsics", &notes);
  m.d_query = DepthMap();
  r.ref_intrinsics = m.ref_intrinsics;
  if (m.depth->needs_provided() && (m.d_ref.empty() || in.depth.empty())) {
    // Which map is missing, the given intrinsics kept as given (nothing was estimated).
    r.status = QueryStatus::kNoDepth;
    r.message = NoDepthMessage(m.d_ref.empty(), m.ref_depth_name, in.depth.empty(), in.depth.source, m.o);
    r.query_intrinsics.camera = in.intrinsics_source == IntrinsicsSource::kPointmap ? Camera() : camera;
    r.query_intrinsics.source =
        in.intrinsics_source == IntrinsicsSource::kPointmap ? IntrinsicsSource::kNone : in.intrinsics_source;
    r.query_intrinsics.orientation = in.orientation;
    r.input_notes = notes.notes;
    return r;
  }
  in.depth = CheckedDepth(std::move(in.depth), wf, m.o, "query depth", &notes);
  std::vector<uint16_t> labels;
  std::vector<Eigen::Vector4d> rows;
  InputsToWorking(wf, &m.ref_scale, &in, &labels, &rows);
  const Camera k_work = wf.ToWorking(camera);
  r.timings.prepare_ms = MsSince(tp);
  // Matching first: a focal estimated from the query's pointmap comes from it, and the depth stage needs the focal.
  DepthMap provided = std::move(in.depth);
  SetStage("query: matching");
  matching::Correspondences c = m.matcher->Match(wf.image(), k_work, in, &r);
  const auto tf = std::chrono::steady_clock::now();
  const FrameIntrinsics fi = ResolveIntrinsics(
      k_work, in, wf.image(), m.o, [&] { return m.matcher->QueryFocal(); }, "query");
  r.query_intrinsics = InPhotoPixels(fi, camera, wf);
  r.timings.match_ms += MsSince(tf);
  const double own_before_depth = m.matcher->own_pass_ms();
  const Camera& k_query = fi.camera;
  const auto t0 = std::chrono::steady_clock::now();
  SetStage("query: depth");
  m.d_query = m.depth->Depth(wf.image(), k_query, std::move(provided));
  r.timings.depth_ms = m.depth->needs_provided() ? 0.0 : MsSince(t0);
  if (m.o.UsesMast3rDepth()) {
    // MASt3R's own metric depth of this pair (the reference's changes with the query: pointmaps are per pair).
    const auto t1 = std::chrono::steady_clock::now();
    FREELOC_CHECK(m.matcher->PairDepth(m.o.solver != SolverKind::kPnp, &m.d_ref, &m.d_query),
                  "depth mast3r: the matcher " << m.o.matcher.ToString() << " gives no depth");
    r.timings.depth_ms = MsSince(t1);
  }
  // The query's own-pointmap pass is reported inside match_ms, like the pair's, wherever it ran (the focal check
  // runs it before the depth stage; without the check MASt3R's query depth runs it inside that stage).
  r.timings.own_pass_ms = m.matcher->own_pass_ms();
  const double own_in_depth = r.timings.own_pass_ms - own_before_depth;
  r.timings.depth_ms = std::max(0.0, r.timings.depth_ms - own_in_depth);
  r.timings.match_ms += own_in_depth;
  SetStage("query: solving");
  m.solver->Solve(c, m.k_ref, k_query, m.d_ref, m.d_query, &r);
  if (m.o.UsesProvidedDepth() && m.o.solver != SolverKind::kPnp)
    inputs::CheckDepthAgreement(c, m.k_ref, k_query, m.d_ref, m.d_query, &r);
  ApplyInputNotes(notes, &r);
  if (matches) {
    wf.ToPhoto(&c, m.ref_scale);
    *matches = std::move(c);
  }
  m.UpdateStats();
  return r;
}

QueryResult RelocalizePair(const Image& ref, const Image& query, const Camera& k_ref, const Camera& k_query,
                           const DepthMap& d_ref, const DepthMap& d_query, const PipelineOptions& o,
                           const std::vector<Eigen::Vector4d>* pre, matching::Correspondences* matches) {
  Relocalizer r(o);
  r.SetReference(ref, k_ref, d_ref);
  return r.Relocalize(query, k_query, d_query, pre, matches);
}

QueryResult SolveCorrespondences(const matching::Correspondences& c, const Camera& k_ref, const Camera& k_query,
                                 DepthMap d_ref, DepthMap d_query, const PipelineOptions& o) {
  // No photo here: a depth map's size stands for its image's where the frame's correspondences lie inside it (one
  // that does not cover them is the solver's error, pose/estimate_pose.cc CheckDepthCovers).
  const auto size_of = [](const DepthMap& d, const std::vector<Eigen::Vector2d>& px, int* w, int* h) {
    size_t inside = 0;
    for (const auto& p : px) inside += p.x() >= -0.5 && p.y() >= -0.5 && p.x() < d.width && p.y() < d.height;
    const bool covers = !d.empty() && inside * 5 >= px.size() * 4;
    *w = covers ? d.width : 0;
    *h = covers ? d.height : 0;
  };
  int wr, hr, wq, hq;
  size_of(d_ref, c.ref, &wr, &hr);
  size_of(d_query, c.query, &wq, &hq);
  inputs::InputNotes notes;
  inputs::CheckIntrinsics(k_ref, wr, hr, o.inputs, "reference intrinsics", &notes);
  inputs::CheckIntrinsics(k_query, wq, hq, o.inputs, "query intrinsics", &notes);
  d_ref = inputs::CheckProvidedDepth(std::move(d_ref), 0, 0, 0, 0, o.inputs, "reference depth", &notes);
  d_query = inputs::CheckProvidedDepth(std::move(d_query), 0, 0, 0, 0, o.inputs, "query depth", &notes);
  QueryResult r;
  MakePoseSolver(o)->Solve(c, k_ref, k_query, d_ref, d_query, &r);
  if (o.solver != SolverKind::kPnp) inputs::CheckDepthAgreement(c, k_ref, k_query, d_ref, d_query, &r);
  ApplyInputNotes(notes, &r);
  AnswerUnsolved(o, &r);
  return r;
}

}  // namespace freeloc::pipeline

// The `freeloc._freeloc` extension (pybind11): the same pipeline as the CLI behind a numpy-in, numpy-out API. Only
// argument translation lives here — options go through pipeline::SetOption (the typed option table), poses through
// the pipeline's PoseSolver and Relocalizer, runs through the run controller, metrics through eval, the networks one
// by one through the networks module's table (pipeline/networks.h; no nn/ or vision/ header here). The GIL is
// released during every long call. python/freeloc/__init__.py adds the pure-Python conveniences.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "freeloc/core/env.h"
#include "freeloc/core/error.h"
#include "freeloc/core/limits.h"
#include "freeloc/core/version.h"
#include "freeloc/eval/report.h"
#include "freeloc/inputs/intrinsics.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/pipeline/multi_frame.h"
#include "freeloc/pipeline/networks.h"
#include "freeloc/pipeline/record.h"
#include "freeloc/pipeline/relocalizer.h"
#include "freeloc/pipeline/run_controller.h"
#include "freeloc/pipeline/run_fields.h"
#include "freeloc/service/service_fields.h"

namespace py = pybind11;

namespace freeloc::python {

namespace {

// Errors in what the caller passed (options, shapes, dtypes) are ValueErrors; everything else freeloc.Error.
[[noreturn]] void BadValue(const std::string& text) { throw py::value_error(text); }

// ---------------------------------------------------------------------------------------------------------------
// Arguments

// A keyword value as the option table's text: str as is, int and float exactly, bool refused.
std::string OptionText(const std::string& name, const py::handle& v) {
  if (py::isinstance<py::bool_>(v)) BadValue(name + ": expected a number or a string, got a bool");
  if (py::isinstance<py::int_>(v)) return std::to_string(v.cast<long long>());
  if (py::isinstance<py::float_>(v)) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.17g", v.cast<double>());
    return buf;
  }
  if (py::isinstance<py::str>(v)) return v.cast<std::string>();
  BadValue(name + ": expected a number or a string, got " + std::string(py::str(v.get_type().attr("__name__"))));
}

// Applies keyword options by their pipeline names; an unknown name or a bad value is a ValueError naming it.
void ApplyOptions(pipeline::PipelineOptions* o, const py::kwargs& kw, const std::vector<std::string>& skip = {}) {
  for (const auto& [k, v] : kw) {
    const std::string name = py::str(k);
    if (std::find(skip.begin(), skip.end(), name) != skip.end()) continue;
    try {
      pipeline::SetOption(o, name, OptionText(name, v));
    } catch (const Error& e) {
      BadValue(e.what());
    }
  }
}

void Validate(const pipeline::PipelineOptions& o) {
  try {
    o.Validate();
  } catch (const Error& e) {
    BadValue(e.what());
  }
}

// A 3×3 intrinsics matrix (any real dtype) → Camera; `width`/`height` when known.
Camera CameraOf(const py::handle& k, const char* what, int width = 0, int height = 0) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(k);
  if (!a || a.ndim() != 2 || a.shape(0) != 3 || a.shape(1) != 3)
    BadValue(std::string(what) + ": expected a 3x3 matrix");
  const auto m = a.unchecked<2>();
  Camera c{m(0, 0), m(1, 1), m(0, 2), m(1, 2), width, height};
  if (!(std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) && std::isfinite(c.cy)) || c.fx <= 0 ||
      c.fy <= 0 || m(2, 0) != 0 || m(2, 1) != 0 || m(2, 2) != 1)
    BadValue(std::string(what) + ": expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with positive finite focals");
  try {
    c.Validate(what);  // the map-free reader's bounds (with the image's size when known)
  } catch (const Error& e) {
    BadValue(e.what());
  }
  return c;
}

// N×2 pixel coordinates (any real dtype, any strides).
std::vector<Eigen::Vector2d> Points(const py::handle& x, const char* what) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(x);
  if (!a || a.ndim() != 2 || a.shape(1) != 2) BadValue(std::string(what) + ": expected an N x 2 array of pixels");
  const auto m = a.unchecked<2>();
  std::vector<Eigen::Vector2d> p(static_cast<size_t>(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    p[static_cast<size_t>(i)] = {m(i, 0), m(i, 1)};
    if (!std::isfinite(m(i, 0)) || !std::isfinite(m(i, 1)))
      BadValue(std::string(what) + ": row " + std::to_string(i) + " is not finite");
  }
  return p;
}

bool IsPath(const py::handle& v) { return py::isinstance<py::str>(v) || py::hasattr(v, "__fspath__"); }
std::string PathOf(const py::handle& v) { return py::str(py::module_::import("os").attr("fspath")(v)); }

// A path, an H×W float array of metres, or an H×W uint16 array (the map-free PNG values, as cv2.imread(…,
// IMREAD_UNCHANGED) gives them: millimetres, or the `depth_unit` keyword's unit); 0 = invalid; None → empty.
DepthMap DepthOf(const py::handle& d, const char* what) {
  if (d.is_none()) return {};
  if (IsPath(d)) return io::ReadDepthPng(PathOf(d));
  const py::array raw = py::array::ensure(d);
  if (!raw || raw.ndim() != 2)
    BadValue(std::string(what) + ": expected a path, an H x W float array of metres or an H x W uint16 array of mm");
  const bool millimetres = raw.dtype().is(py::dtype::of<uint16_t>());
  if (!millimetres && raw.dtype().kind() != 'f')
    BadValue(std::string(what) + ": depth arrays are float (metres) or uint16 (millimetres), not " +
             std::string(py::str(raw.dtype())));
  const auto a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(raw);
  DepthMap m;
  m.width = static_cast<int>(a.shape(1));
  m.height = static_cast<int>(a.shape(0));
  m.data.assign(a.data(), a.data() + a.size());
  if (millimetres) {
    for (float& v : m.data) v = static_cast<float>(v / 1000.0);
    m.storage = DepthStorage::kInteger;  // the `depth_unit` keyword says what its integers are (mm by default)
  }
  for (float& v : m.data) v = (v > 0.f && v <= std::numeric_limits<float>::max()) ? v : 0.f;  // NaN, inf, ≤ 0: invalid
  m.source = what;
  return m;
}

// A path, or an H×W×3 uint8 RGB array.
Image ImageOf(const py::handle& v, const char* what) {
  if (IsPath(v)) return io::ReadImage(PathOf(v));
  const py::array arr = py::array::ensure(v);
  if (!arr || !arr.dtype().is(py::dtype::of<uint8_t>()) || arr.ndim() != 3 || arr.shape(2) != 3)
    BadValue(std::string(what) + ": expected a path or an H x W x 3 uint8 RGB array");
  const auto a = py::array_t<uint8_t, py::array::c_style | py::array::forcecast>::ensure(arr);
  Image im(static_cast<int>(a.shape(1)), static_cast<int>(a.shape(0)));
  std::memcpy(im.data.data(), a.data(), im.data.size());
  return im;
}

// ---------------------------------------------------------------------------------------------------------------
// Results

// A JSON text of the library (records, options) as Python objects.
py::object JsonToPy(const std::string& json) { return py::module_::import("json").attr("loads")(json); }

struct PoseResult {
  pipeline::QueryResult r;
  pipeline::PipelineOptions options;
  size_t n = 0;  // correspondences into the solver
};

py::array_t<bool> InlierArray(const PoseResult& p) {
  py::array_t<bool> a(static_cast<py::ssize_t>(p.n));
  auto m = a.mutable_unchecked<1>();
  for (size_t i = 0; i < p.n; ++i) m(static_cast<py::ssize_t>(i)) = i < p.r.inlier_mask.size() && p.r.inlier_mask[i];
  return a;
}

py::array_t<double> Array(const std::vector<double>& v, std::vector<py::ssize_t> shape) {
  py::array_t<double> a(shape);
  std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(double));
  return a;
}

py::array TensorArray(const io::TensorView& t) {
  std::vector<py::ssize_t> shape(t.shape.begin(), t.shape.end());
  if (t.dtype == io::DType::kU8) {
    py::array_t<uint8_t> a(shape);
    std::memcpy(a.mutable_data(), t.data, t.nbytes);
    return a;
  }
  const std::vector<float> f = t.ToFloat();
  py::array_t<float> a(shape);
  std::memcpy(a.mutable_data(), f.data(), f.size() * sizeof(float));
  return a;
}

py::dict AsDict(const PoseResult& p) { return JsonToPy(pipeline::QueryRecordJson("", p.r, &p.options)); }

// ---------------------------------------------------------------------------------------------------------------
// Entry points

PoseResult EstimateRelativePose(const py::handle& x_ref, const py::handle& x_query, const py::handle& k_ref,
                                const py::handle& k_query, const py::handle& depth_ref, const py::handle& depth_query,
                                const py::kwargs& kw) {
  const std::vector<Eigen::Vector2d> a = Points(x_ref, "x_ref"), b = Points(x_query, "x_query");
  if (a.size() != b.size())
    BadValue("x_ref and x_query differ in length (" + std::to_string(a.size()) + " vs " + std::to_string(b.size()) +
             ")");
  const Camera kr = CameraOf(k_ref, "K_ref"), kq = CameraOf(k_query, "K_query");
  const DepthMap dr = DepthOf(depth_ref, "depth_ref"), dq = DepthOf(depth_query, "depth_query");
  pipeline::PipelineOptions o = pipeline::CorrespondenceDefaults();
  if (kw.contains("preset")) {
    try {
      o = pipeline::ResolvePreset(OptionText("preset", kw["preset"]));
    } catch (const Error& e) {
      BadValue(e.what());
    }
  }
  ApplyOptions(&o, kw, {"preset"});
  o = pipeline::ForCorrespondences(o, !dr.empty());
  if (dr.empty() != dq.empty() && o.solver != pipeline::SolverKind::kPnp)
    BadValue("give both depth_ref and depth_query (or neither); only solver='pnp' uses the reference depth alone");
  Validate(o);
  PoseResult p;
  p.options = o;
  p.n = a.size();
  matching::Correspondences c;
  c.ref = a;
  c.query = b;
  {
    py::gil_scoped_release nogil;
    p.r = pipeline::SolveCorrespondences(c, kr, kq, dr, dq, o);
  }
  return p;
}

// A Relocalizer over the pipeline: the reference's work is redone only when another reference comes.
class PyRelocalizer {
 public:
  PyRelocalizer(const std::string& preset, const py::object& models, const py::kwargs& kw) {
    try {
      options_ = pipeline::ResolvePreset(preset);
    } catch (const Error& e) {
      BadValue(e.what());
    }
    if (!models.is_none()) options_.models.models_dir = PathOf(models);
    ApplyOptions(&options_, kw);
    depth_overridden_ = kw.contains("depth");
    pipeline::FindModels(&options_);
    Validate(options_);
  }

  PoseResult Relocalize(const py::handle& ref, const py::handle& query, const py::handle& k_ref,
                        const py::handle& k_query, const py::handle& depth_ref, const py::handle& depth_query) {
    pipeline::FrameInputs in_ref, in_query;
    Image ri, qi;
    const Camera kr = PhotoOf(ref, k_ref, "ref_image", "K_ref", &ri, &in_ref);
    const Camera kq = PhotoOf(query, k_query, "query_image", "K_query", &qi, &in_query);
    in_ref.depth = DepthOf(depth_ref, "depth_ref");
    in_query.depth = DepthOf(depth_query, "depth_query");
    // As `freeloc relocalize`: no depth given and none overridden → the provided-depth presets answer without depth.
    const bool any_depth = !in_ref.depth.empty() || !in_query.depth.empty();
    return Answer(any_depth, ri, kr, std::move(in_ref),
                  [&](pipeline::Relocalizer& reloc, matching::Correspondences* c) {
                    return reloc.Relocalize(qi, kq, std::move(in_query), c);
                  });
  }

  // The Multi Frame track's query: `frames` oldest first, the evaluated frame last (1–9); per frame its K (or one
  // K for all, or none: EXIF), its depth map and its device pose (4×4 frame_from_query, or None).
  PoseResult RelocalizeWindow(const py::handle& ref, const py::list& frames, const py::handle& k_ref,
                              const py::handle& ks, const py::handle& depth_ref, const py::handle& depths,
                              const py::handle& device_poses) {
    const size_t n = frames.size();
    if (n < 1 || n > 9)
      BadValue("frames: give 1 to 9 frames (oldest first, the evaluated frame last), got " + std::to_string(n));
    auto per_frame = [&](const py::handle& v, const char* what) -> std::vector<py::object> {
      std::vector<py::object> out(n, py::none());
      if (v.is_none()) return out;
      if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
        const py::sequence seq = py::reinterpret_borrow<py::sequence>(v);
        if (seq.size() != n)
          BadValue(std::string(what) + ": give one per frame (" + std::to_string(n) + "), got " +
                   std::to_string(seq.size()));
        for (size_t i = 0; i < n; ++i) out[i] = seq[i];
        return out;
      }
      for (auto& o : out) o = py::reinterpret_borrow<py::object>(v);  // one value for every frame
      return out;
    };
    const auto k_list = per_frame(ks, "Ks");
    const auto d_list = per_frame(depths, "depths");
    const auto p_list =
        device_poses.is_none() ? std::vector<py::object>(n, py::none()) : per_frame(device_poses, "device_poses");
    pipeline::FrameInputs in_ref;
    Image ri;
    const Camera kr = PhotoOf(ref, k_ref, "ref_image", "K_ref", &ri, &in_ref);
    in_ref.depth = DepthOf(depth_ref, "depth_ref");
    std::vector<pipeline::WindowFrame> window(n);
    bool any_depth = !in_ref.depth.empty();
    for (size_t i = 0; i < n; ++i) {
      pipeline::WindowFrame& f = window[i];
      f.name = "frame " + std::to_string(i);
      f.camera = PhotoOf(frames[i], k_list[i], "frames[i]", "Ks[i]", &f.image, &f.inputs);
      f.inputs.depth = DepthOf(d_list[i], "depths[i]");
      any_depth = any_depth || !f.inputs.depth.empty();
      if (!p_list[i].is_none()) {
        const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(p_list[i]);
        if (!a || a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
          BadValue("device_poses[" + std::to_string(i) + "]: expected a 4x4 matrix (frame_from_query) or None");
        Eigen::Matrix3d R;
        Eigen::Vector3d t;
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 3; ++c) R(r, c) = a.at(r, c);
          t(r) = a.at(r, 3);
        }
        if (!R.allFinite() || !t.allFinite() || (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 ||
            R.determinant() < 0)
          BadValue("device_poses[" + std::to_string(i) + "]: the upper 3x3 is not a rotation");
        f.has_device = true;
        f.device_from_query = Rigid3d(R, t);
      }
    }
    return Answer(any_depth, ri, kr, std::move(in_ref),
                  [&](pipeline::Relocalizer& reloc, matching::Correspondences* c) {
                    return pipeline::RelocalizeWindow(reloc, std::move(window), c);
                  });
  }

  const pipeline::PipelineOptions& options() const { return options_; }

 private:
  // An image (a path: decoded upright, with its EXIF; an array: as is) and its intrinsics by freeloc's order
  // (inputs/intrinsics.h): `k` when given, else the photo's EXIF, else the pointmap's focal (dust3r/mast3r
  // presets), else a ValueError naming the keyword.
  Camera PhotoOf(const py::handle& image, const py::handle& k, const char* image_name, const char* k_name, Image* out,
                 pipeline::FrameInputs* in) const {
    io::ExifInfo exif;
    *out = IsPath(image) ? io::ReadImage(PathOf(image), &exif) : ImageOf(image, image_name);
    Camera given;
    if (!k.is_none()) given = CameraOf(k, k_name, out->width, out->height);
    const inputs::IntrinsicsChoice c =
        inputs::ChooseIntrinsics(k.is_none() ? nullptr : &given, pipeline::IntrinsicsSource::kGiven, exif, *out,
                                 options_.UsesPointmapModel(), image_name);
    if (c.source == pipeline::IntrinsicsSource::kNone)
      BadValue(std::string(k_name) + ": not given, and " + image_name + " has no usable EXIF focal length (" + c.why +
               "); pass " + k_name +
               " (3x3) or use a dust3r or mast3r preset (they estimate the focal from the "
               "pointmap)");
    return pipeline::ApplyIntrinsics(c, in);
  }

  // The reference set (its work redone only when it changed), then `query` on the relocalizer, without the GIL.
  // Without any depth given and none overridden the provided-depth presets answer without depth, as `freeloc
  // relocalize` does.
  PoseResult Answer(
      bool any_depth, const Image& ri, const Camera& kr, pipeline::FrameInputs in_ref,
      const std::function<pipeline::QueryResult(pipeline::Relocalizer&, matching::Correspondences*)>& query) {
    const bool no_depth = !any_depth && !depth_overridden_ && options_.UsesProvidedDepth();
    PoseResult p;
    p.options = options_;
    if (no_depth) p.options.depth = pipeline::DepthSpec::FromString("none");
    pipeline::Relocalizer& reloc = Get(no_depth);
    matching::Correspondences c;
    {
      py::gil_scoped_release nogil;
      if (!SameReference(no_depth, ri, kr, in_ref)) reloc.SetReference(ri, kr, std::move(in_ref));
      p.r = query(reloc, &c);
    }
    p.n = c.size();
    return p;
  }

  struct Slot {
    std::unique_ptr<pipeline::Relocalizer> reloc;
    Image ref;
    Camera k;
    pipeline::IntrinsicsSource source = pipeline::IntrinsicsSource::kNone;
    int orientation = 0;
    DepthMap depth;
    bool set = false;
  };

  pipeline::Relocalizer& Get(bool no_depth) {
    Slot& s = slots_[no_depth];
    if (!s.reloc) {
      pipeline::PipelineOptions o = options_;
      if (no_depth) o.depth = pipeline::DepthSpec::FromString("none");
      s.reloc = std::make_unique<pipeline::Relocalizer>(o, pipeline::Relocalizer::kOptionsValidated);  // in the ctor
    }
    return *s.reloc;
  }

  // Whether the slot's reference is this one (same pixels, camera and its source, depth); remembers it when not.
  bool SameReference(bool no_depth, const Image& im, const Camera& k, const pipeline::FrameInputs& in) {
    Slot& s = slots_[no_depth];
    const DepthMap& d = in.depth;
    const bool same = s.set && s.ref.width == im.width && s.ref.height == im.height && s.ref.data == im.data &&
                      s.k.fx == k.fx && s.k.fy == k.fy && s.k.cx == k.cx && s.k.cy == k.cy &&
                      s.source == in.intrinsics_source && s.orientation == in.orientation && s.depth.width == d.width &&
                      s.depth.data == d.data;
    if (!same) {
      s.ref = im;
      s.k = k;
      s.source = in.intrinsics_source;
      s.orientation = in.orientation;
      s.depth = d;
      s.set = true;
    }
    return same;
  }

  pipeline::PipelineOptions options_;
  bool depth_overridden_ = false;
  std::map<bool, Slot> slots_;
};

std::string Evaluate(const std::string& data, const std::string& submission, const std::string& split,
                     const std::vector<std::string>& scenes, const std::string& track) {
  io::Track t = io::Track::kSingleFrame;
  try {
    t = ParseEnum<io::Track>(track);
  } catch (const Error& e) {
    BadValue(e.what());
  }
  py::gil_scoped_release nogil;
  std::string split_dir;
  const std::vector<std::string> list = pipeline::ResolveScenes(data, split, scenes, &split_dir);
  return eval::JsonReport(eval::RunEvaluation(split_dir, list, submission, t));
}

// A run-family keyword's value as its text form (run_fields.h): lists comma-joined, bools 1/0.
std::string RunFieldText(const std::string& name, const py::handle& v) {
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>() ? "1" : "0";
  if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
    std::string s;
    for (const auto& e : v) s += (s.empty() ? "" : ",") + py::str(e).cast<std::string>();
    return s;
  }
  return OptionText(name, v);
}

py::dict Run(const std::string& data, const std::string& out, const std::string& preset, const py::object& models,
             const py::object& progress, const py::kwargs& kw) {
  pipeline::PipelineOptions o;
  try {
    o = pipeline::ResolvePreset(preset);
  } catch (const Error& e) {
    BadValue(e.what());
  }
  if (!models.is_none()) o.models.models_dir = PathOf(models);
  // Run fields (pipeline/run_fields.h) by their names; every other keyword is a pipeline option.
  pipeline::RunSpec spec;
  std::vector<std::string> run_names;
  for (const FamilyField& f : pipeline::RunFamily().fields) run_names.push_back(f.name);
  try {
    pipeline::SetRunField(&spec, "data", data);
    pipeline::SetRunField(&spec, "out", out);
    for (const auto& [k, v] : kw) {
      const std::string name = py::str(k);
      if (std::find(run_names.begin(), run_names.end(), name) != run_names.end())
        pipeline::SetRunField(&spec, name, RunFieldText(name, v));
    }
  } catch (const Error& e) {
    BadValue(e.what());
  }
  ApplyOptions(&o, kw, run_names);
  pipeline::FindModels(&o);  // validated once, by ExecuteRun (an option's error is a ValueError naming it)
  spec.progress_bar = false;
  if (!progress.is_none()) {
    spec.on_progress = [progress](int64_t done, int64_t total) {
      py::gil_scoped_acquire gil;
      progress(done, total);
    };
  }
  pipeline::RunResult r;
  {
    py::gil_scoped_release nogil;
    r = pipeline::ExecuteRun(spec, o);
  }
  py::dict d;
  d["scenes"] = r.scenes;
  d["queries"] = r.queries;
  d["solved"] = r.solved;
  d["submitted"] = r.submitted;
  d["resumed_scenes"] = r.resumed_scenes;
  d["statuses"] = r.statuses;
  d["input_errors"] = r.input_errors;  // queries that failed on a damaged or unreadable file (status error)
  d["input_error_messages"] = r.input_error_messages;
  if (r.input_errors > 0) {  // as the command says it (and exits 3): never a silent "0 of N"
    const std::string msg = std::to_string(r.input_errors) + " of " + std::to_string(r.queries) +
                            " queries failed on input errors (status error); first: " +
                            (r.input_error_messages.empty() ? std::string() : r.input_error_messages[0]) +
                            " — see result['input_error_messages']";
    if (PyErr_WarnEx(PyExc_RuntimeWarning, msg.c_str(), 1) != 0) throw py::error_already_set();
  }
  py::dict per_scene;
  for (const auto& [name, results] : r.results) {
    py::list l;
    for (const auto& q : results) l.append(JsonToPy(pipeline::QueryRecordJson(name, q)));
    per_scene[py::str(name)] = l;
  }
  d["results"] = per_scene;
  return d;
}

nn::RuntimeOptions RuntimeOf(const std::string& device, const std::string& precision, int threads) {
  nn::RuntimeOptions rt;
  try {
    rt.device = ParseEnum<nn::Device>(device);
    rt.precision = ParseEnum<nn::Precision>(precision);
  } catch (const Error& e) {
    BadValue(e.what());
  }
  rt.threads = threads;
  return rt;
}

// A network of the networks module (pipeline/networks.h), loaded for the given runtime; one wrapper type per Python
// class.
template <pipeline::BoundNetwork Kind>
struct PyNetwork {
  std::shared_ptr<void> net;
};

template <pipeline::BoundNetwork Kind>
auto NetworkInit() {
  return py::init([](const py::object& path, const py::object& config, const std::string& device,
                     const std::string& precision, int threads) {
    return PyNetwork<Kind>{pipeline::Networks().load_network(Kind, PathOf(path), config.is_none() ? "" : PathOf(config),
                                                             RuntimeOf(device, precision, threads))};
  });
}
using PyDust3r = PyNetwork<pipeline::BoundNetwork::kDust3r>;
using PyMetric3d = PyNetwork<pipeline::BoundNetwork::kMetric3d>;
using PySegGpt = PyNetwork<pipeline::BoundNetwork::kSegGpt>;

py::dict TensorDict(const pipeline::NamedTensors& t) {
  py::dict d;
  for (const auto& [name, tensor] : t) d[name.c_str()] = TensorArray(tensor);
  return d;
}

// DUSt3R / MASt3R on a pair: the `freeloc pointmap` outputs (MASt3R: also desc_1/desc_conf_1/desc_2/desc_conf_2).
py::dict Dust3rPair(const PyDust3r& m, const py::handle& img1, const py::handle& img2, int size) {
  const Image a = ImageOf(img1, "image_1"), b = ImageOf(img2, "image_2");
  pipeline::NamedTensors t;
  {
    py::gil_scoped_release nogil;
    t = pipeline::Networks().run_pointmaps(m.net, a, b, size);
  }
  return TensorDict(t);
}

// Metric3D v2 on one image: the `freeloc depth --raw` outputs.
py::dict Metric3dEstimate(const PyMetric3d& m, const py::handle& image, const py::handle& k) {
  const Image im = ImageOf(image, "image");
  const Camera cam = CameraOf(k, "K", im.width, im.height);
  pipeline::NamedTensors t;
  {
    py::gil_scoped_release nogil;
    t = pipeline::Networks().run_depth(m.net, im, cam);
  }
  return TensorDict(t);
}

// SegGPT: the target's mask from prompts (the `freeloc segment` output).
py::dict SegGptSegment(const PySegGpt& m, const py::list& prompt_images, const py::list& prompt_masks,
                       const py::handle& target, const std::string& type) {
  if (prompt_images.size() == 0 || prompt_images.size() != prompt_masks.size())
    BadValue("give one prompt mask per prompt image (and at least one)");
  if (type != "instance" && type != "semantic") BadValue("type: '" + type + "' is not one of instance, semantic");
  std::vector<Image> pi, pm;
  for (size_t k = 0; k < prompt_images.size(); ++k) {
    pi.push_back(ImageOf(prompt_images[k], "prompt_images"));
    pm.push_back(ImageOf(prompt_masks[k], "prompt_masks"));
  }
  const Image t = ImageOf(target, "target");
  std::vector<uint8_t> mask;
  {
    py::gil_scoped_release nogil;
    mask = pipeline::Networks().run_segment(m.net, pi, pm, t, type);
  }
  py::array_t<bool> a({static_cast<py::ssize_t>(t.height), static_cast<py::ssize_t>(t.width)});
  auto w = a.mutable_unchecked<2>();
  for (int y = 0; y < t.height; ++y)
    for (int x = 0; x < t.width; ++x) w(y, x) = mask[static_cast<size_t>(y) * t.width + x] != 0;
  py::dict d;
  d["mask"] = a;
  return d;
}

}  // namespace
}  // namespace freeloc::python

namespace freeloc::python {
namespace {

// read_depth, read_image.
void BindFiles(py::module_& m) {
  m.def(
      "read_depth",
      [](const py::object& path) {
        const DepthMap d = io::ReadDepthPng(PathOf(path));
        py::array_t<float> a({static_cast<py::ssize_t>(d.height), static_cast<py::ssize_t>(d.width)});
        std::memcpy(a.mutable_data(), d.data.data(), d.data.size() * sizeof(float));
        return a;
      },
      py::arg("path"), "The map-free uint16 millimetre PNG as float32 metres (0 = invalid).");

  m.def(
      "read_intrinsics",
      [](const py::object& path) {
        io::ExifInfo exif;
        const std::string p = PathOf(path);
        const Image im = io::ReadImage(p, &exif);
        const inputs::IntrinsicsChoice c =
            inputs::ChooseIntrinsics(nullptr, pipeline::IntrinsicsSource::kGiven, exif, im, false, p);
        py::dict d;
        d["width"] = im.width;
        d["height"] = im.height;
        d["orientation"] = exif.orientation;
        d["source"] = c.source == pipeline::IntrinsicsSource::kExif ? "exif" : "none";
        d["why"] = c.why;
        if (c.source == pipeline::IntrinsicsSource::kExif) {
          py::array_t<double> k({py::ssize_t{3}, py::ssize_t{3}});
          auto m = k.mutable_unchecked<2>();
          const double v[9] = {c.camera.fx, 0, c.camera.cx, 0, c.camera.fy, c.camera.cy, 0, 0, 1};
          for (int i = 0; i < 9; ++i) m(i / 3, i % 3) = v[i];
          d["K"] = k;
        } else {
          d["K"] = py::none();
        }
        return d;
      },
      py::arg("path"),
      "What freeloc reads from a photo's EXIF: {'K': 3x3 or None, 'source': 'exif' or 'none', 'why', 'orientation', "
      "'width', 'height'} for the image as decoded (upright). Without EXIF intrinsics a dust3r/mast3r Relocalizer "
      "estimates the focal from the pointmap.");

  m.def(
      "read_image",
      [](const py::object& path) {
        const Image im = io::ReadImage(PathOf(path));
        py::array_t<uint8_t> a(
            {static_cast<py::ssize_t>(im.height), static_cast<py::ssize_t>(im.width), py::ssize_t{3}});
        std::memcpy(a.mutable_data(), im.data.data(), im.data.size());
        return a;
      },
      py::arg("path"),
      "An image file as an H x W x 3 uint8 RGB array (EXIF orientation applied), as freeloc reads it.");
}

// PoseResult, estimate_relative_pose, Relocalizer.
void BindPoses(py::module_& m) {
  py::class_<PoseResult>(m, "PoseResult", "A pose query_from_ref (x_query = R·x_ref + t) with its status.")
      .def_property_readonly("status", [](const PoseResult& p) { return ToString(p.r.status); })
      .def_property_readonly("message", [](const PoseResult& p) { return p.r.message; })
      .def_property_readonly(
          "inputs", [](const PoseResult& p) { return p.r.input_notes; },
          "what the plausible-input checks did (a resampled depth map, a loosened bound); each lowers the confidence")
      .def_property_readonly(
          "solved", [](const PoseResult& p) { return p.r.solved(); },
          "status ok or ok-unit-translation: freeloc stands behind the pose")
      .def_property_readonly(
          "submitted", [](const PoseResult& p) { return p.r.submitted(); },
          "a pose goes into a submission: solved, or unsolved under always_answer (status weak-support with its own "
          "pose and a confidence below 1e-3, else the prior pose, identity, with confidence 0)")
      .def_property_readonly(
          "ok", [](const PoseResult& p) { return p.r.ok(); }, "the same as solved (the name before 0.x)")
      .def_property_readonly("metric", [](const PoseResult& p) { return p.r.metric(); })
      .def_property_readonly(
          "answered",
          [](const PoseResult&) -> bool {
            throw py::attribute_error(
                "PoseResult.answered is gone (it was True for an unsolved query): use .solved (freeloc stands behind "
                "the pose) or .submitted (a pose goes into the submission)");
          },
          "gone: use solved or submitted")
      .def_property_readonly(
          "route", [](const PoseResult& p) { return p.r.RouteText(); },
          "the solver's route: essential, hybrid, hybrid>essential (fell back), pnp, procrustes")
      .def_property_readonly("qvec",
                             [](const PoseResult& p) {
                               const auto q = p.r.query_from_ref.QuaternionWxyz();
                               return Array({q[0], q[1], q[2], q[3]}, {4});
                             })
      .def_property_readonly(
          "R",
          [](const PoseResult& p) {
            const Eigen::Matrix3d R = p.r.query_from_ref.R();
            return Array({R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)}, {3, 3});
          })
      .def_property_readonly("t",
                             [](const PoseResult& p) {
                               const auto& t = p.r.query_from_ref.translation;
                               return Array({t.x(), t.y(), t.z()}, {3});
                             })
      .def_property_readonly("confidence", [](const PoseResult& p) { return p.r.confidence; })
      .def_property_readonly("inliers", &InlierArray)
      .def_property_readonly("num_inliers", [](const PoseResult& p) { return p.r.inliers; })
      .def("as_dict", &AsDict, "The JSON record of `freeloc pose --json` / `relocalize --json`.")
      .def("__repr__", [](const PoseResult& p) {
        return "<PoseResult " + p.r.StatusText() + ", " + std::to_string(p.r.inliers) + " inliers>";
      });

  m.def("estimate_relative_pose", &EstimateRelativePose, py::arg("x_ref"), py::arg("x_query"), py::arg("K_ref"),
        py::arg("K_query"), py::arg("depth_ref") = py::none(), py::arg("depth_query") = py::none(),
        "The pose from correspondences by the pipeline's solver (as `freeloc pose`); keyword options by their "
        "pipeline names (preset=, solver=, scale=, threshold_px=, …).");

  py::class_<PyRelocalizer>(m, "Relocalizer")
      .def(py::init<const std::string&, const py::object&, const py::kwargs&>(), py::arg("preset") = "sift-essential",
           py::arg("models") = py::none())
      .def("relocalize", &PyRelocalizer::Relocalize, py::arg("ref_image"), py::arg("query_image"),
           py::arg("K_ref") = py::none(), py::arg("K_query") = py::none(), py::arg("depth_ref") = py::none(),
           py::arg("depth_query") = py::none())
      .def("relocalize_window", &PyRelocalizer::RelocalizeWindow, py::arg("ref_image"), py::arg("frames"),
           py::arg("K_ref") = py::none(), py::arg("Ks") = py::none(), py::arg("depth_ref") = py::none(),
           py::arg("depths") = py::none(), py::arg("device_poses") = py::none(),
           "The Multi Frame track: the last of `frames` (oldest first, 1–9) relocalized from its whole window, with "
           "per-frame Ks, depths and device poses (4x4 frame_from_query or None); as_dict()['window'] says how the "
           "frames voted.")
      .def_property_readonly("options",
                             [](const PyRelocalizer& r) { return JsonToPy(pipeline::OptionsJson(r.options())); });
}

// _evaluate, run, option and preset names.
void BindRuns(py::module_& m) {
  m.def("_evaluate", &Evaluate, py::arg("data"), py::arg("submission"), py::arg("split") = "val",
        py::arg("scenes") = std::vector<std::string>{}, py::arg("track") = "single-frame");
  m.def("run", &Run, py::arg("data"), py::arg("out"), py::arg("preset") = "sift-essential",
        py::arg("models") = py::none(), py::arg("progress") = py::none(),
        "Every query of every scene into a submission ZIP (as `freeloc run`); the run fields (split, scenes, log, "
        "report, report_worst, report_per_scene, resume, shard, save_matches: freeloc.option_families()['run']) and "
        "any pipeline option as keywords; progress(done, total) is called after each query.");
  // Every option family by name: {family: [{"name", "flag", "type", "default", "help"}, …]} — the registry the
  // command line and the docs are made from (core/option_family.h).
  m.def("option_families", [] {
    py::dict d;
    const auto fields = [](const OptionFamily& f) {
      py::list l;
      for (const FamilyField& x : f.fields) {
        py::dict e;
        e["name"] = x.name;
        e["flag"] = x.flag;
        e["type"] = FieldTypeText(x.type);
        e["default"] = x.default_text;
        e["help"] = x.help;
        l.append(e);
      }
      return l;
    };
    py::list p;
    for (const auto& f : pipeline::OptionFields()) {
      py::dict e;
      e["name"] = f.name;
      e["flag"] = f.flag ? f.flag : "";
      p.append(e);
    }
    d["pipeline"] = p;
    d["run"] = fields(pipeline::RunFamily());
    d["service"] = fields(service::ServiceFamily());
    d["limits"] = fields(LimitsFamily());
    d["environment"] = fields(EnvironmentFamily());
    return d;
  });
  m.def(
      "set_limit",
      [](const std::string& name, long long value) {
        try {
          SetLimit(name, std::to_string(value));
        } catch (const Error& e) {
          BadValue(e.what());
        }
      },
      py::arg("name"), py::arg("value"), "Raises (or lowers) an input limit for this process (as --limit NAME=N).");
  m.def("option_names", [] {
    std::vector<std::string> n;
    for (const auto& f : pipeline::OptionFields()) n.push_back(f.name);
    return n;
  });
  m.def("preset_names", &pipeline::PresetNames);
}

// Dust3r, Metric3D, SegGPT.
void BindNetworks(py::module_& m) {
  using pipeline::BoundNetwork;
  py::class_<PyDust3r>(m, "Dust3r")
      .def(NetworkInit<BoundNetwork::kDust3r>(), py::arg("path"), py::arg("config") = py::none(),
           py::arg("device") = "cpu", py::arg("precision") = "fp32", py::arg("threads") = 0)
      .def("__call__", &Dust3rPair, py::arg("image_1"), py::arg("image_2"), py::arg("size") = 512)
      .def_property_readonly("family", [](const PyDust3r& d) { return pipeline::Networks().network_family(d.net); });
  py::class_<PyMetric3d>(m, "Metric3D")
      .def(NetworkInit<BoundNetwork::kMetric3d>(), py::arg("path"), py::arg("config") = py::none(),
           py::arg("device") = "cpu", py::arg("precision") = "fp32", py::arg("threads") = 0)
      .def("estimate", &Metric3dEstimate, py::arg("image"), py::arg("K"));
  py::class_<PySegGpt>(m, "SegGPT")
      .def(NetworkInit<BoundNetwork::kSegGpt>(), py::arg("path"), py::arg("config") = py::none(),
           py::arg("device") = "cpu", py::arg("precision") = "fp32", py::arg("threads") = 0)
      .def("segment", &SegGptSegment, py::arg("prompt_images"), py::arg("prompt_masks"), py::arg("target"),
           py::arg("type") = "instance");
}

}  // namespace
}  // namespace freeloc::python

PYBIND11_MODULE(_freeloc, m) {
  using namespace freeloc;          // NOLINT
  using namespace freeloc::python;  // NOLINT
  m.doc() = "freeloc: map-free metric relocalization (C++ core)";
  m.attr("__version__") = Version();
  static py::exception<Error> error(m, "Error");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const OptionError& e) {  // an option's error names the keyword (the option's own name)
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const Error& e) {
      error(e.what());
    }
  });

  BindFiles(m);
  BindPoses(m);
  BindRuns(m);
  BindNetworks(m);
}

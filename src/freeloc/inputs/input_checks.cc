#include "freeloc/inputs/input_checks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "freeloc/core/error.h"
#include "freeloc/geometry/metric_scale.h"

namespace freeloc::inputs {

namespace {

double UnitMetres(DepthUnit u) {
  switch (u) {
    case DepthUnit::kMillimetre: return 1e-3;
    case DepthUnit::kCentimetre: return 1e-2;
    case DepthUnit::kMetre: return 1;
  }
  return 1e-3;
}

const char* UnitWord(DepthUnit u) {
  switch (u) {
    case DepthUnit::kMillimetre: return "millimetres";
    case DepthUnit::kCentimetre: return "centimetres";
    case DepthUnit::kMetre: return "metres";
  }
  return "";
}

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.4g", v);
  return buf;
}

std::string Named(const std::string& frame, const DepthMap& d) {
  return d.source.empty() ? frame : frame + " (" + d.source + ")";
}

// The valid depths' median, smallest and largest, from at most ~65 000 pixels on a regular grid (exact for smaller
// maps). Returns false when no pixel is valid.
bool DepthStatistics(const DepthMap& d, double* median, double* lo, double* hi) {
  const size_t n = d.data.size();
  const size_t step = std::max<size_t>(1, static_cast<size_t>(std::ceil(std::sqrt(n / double(1 << 16)))));
  std::vector<float> v;
  for (int y = 0; y < d.height; y += static_cast<int>(step))
    for (int x = 0; x < d.width; x += static_cast<int>(step))
      if (d.valid(x, y)) v.push_back(d.at(x, y));
  if (v.empty()) return false;
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  *median = *mid;
  const auto mm = std::minmax_element(v.begin(), v.end());
  *lo = *mm.first;
  *hi = *mm.second;
  return true;
}

// `d` resampled to width × height (the same aspect ratio): pixel centres map as x_d = (x + 0.5)·w/W − 0.5; bilinear
// where the four neighbours are valid and agree within 10 %, else the nearest pixel (holes and edges stay sharp).
DepthMap Resample(const DepthMap& d, int width, int height) {
  DepthMap out(width, height);
  out.storage = d.storage;
  out.source = d.source;
  const double sx = static_cast<double>(d.width) / width, sy = static_cast<double>(d.height) / height;
  for (int y = 0; y < height; ++y) {
    const double v = std::clamp((y + 0.5) * sy - 0.5, 0.0, d.height - 1.0);
    const int y0 = static_cast<int>(v), y1 = std::min(y0 + 1, d.height - 1);
    const double fy = v - y0;
    const int yn = static_cast<int>(std::lround(v));
    for (int x = 0; x < width; ++x) {
      const double u = std::clamp((x + 0.5) * sx - 0.5, 0.0, d.width - 1.0);
      const int x0 = static_cast<int>(u), x1 = std::min(x0 + 1, d.width - 1);
      const double fx = u - x0;
      const float a = d.at(x0, y0), b = d.at(x1, y0), c = d.at(x0, y1), e = d.at(x1, y1);
      const bool all = d.valid(x0, y0) && d.valid(x1, y0) && d.valid(x0, y1) && d.valid(x1, y1);
      float value;
      if (all && std::max({a, b, c, e}) <= 1.1f * std::min({a, b, c, e})) {
        value = static_cast<float>((a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + e * fx) * fy);
      } else {
        const int xn = static_cast<int>(std::lround(u));
        value = d.valid(xn, yn) ? d.at(xn, yn) : 0.f;
      }
      out.at(x, y) = value;
    }
  }
  return out;
}

// The unit among mm, cm, m that puts a map's raw median (its stored integers) closest to 2 m, other than `current`.
DepthUnit LikelyUnit(double raw_median, DepthUnit current) {
  DepthUnit best = current;
  double best_err = 1e300;
  for (DepthUnit u : {DepthUnit::kMillimetre, DepthUnit::kCentimetre, DepthUnit::kMetre}) {
    if (u == current) continue;
    const double err = std::abs(std::log(std::max(raw_median * UnitMetres(u), 1e-9) / 2.0));
    if (err < best_err) {
      best_err = err;
      best = u;
    }
  }
  return best;
}

struct Bounds {
  double focal_min, focal_max, aspect, margin;
  explicit Bounds(const InputOptions& o)
      : focal_min(o.focal_min), focal_max(o.focal_max), aspect(o.focal_aspect_max), margin(o.principal_point_margin) {}
};

// Why `k` does not fit a width × height image under `b` (empty: it fits), and the option that loosens it.
std::string Misfit(const Camera& k, int width, int height, const Bounds& b, std::string* option) {
  const double side = std::max(width, height);
  const double f_lo = std::min(k.fx, k.fy), f_hi = std::max(k.fx, k.fy);
  std::ostringstream why;
  if (!(k.fx > 0 && k.fy > 0)) {
    why << "the focal lengths are not positive";
  } else if (f_lo < b.focal_min * side) {
    why << "a focal length of " << Num(f_lo) << " px is below " << Num(b.focal_min) << " × the long side ("
        << Num(b.focal_min * side) << " px)";
    *option = "focal_min";
  } else if (f_hi > b.focal_max * side) {
    why << "a focal length of " << Num(f_hi) << " px is above " << Num(b.focal_max) << " × the long side ("
        << Num(b.focal_max * side) << " px)";
    *option = "focal_max";
  } else if (f_hi > b.aspect * f_lo) {
    why << "fx/fy is " << Num(k.fx / k.fy) << " (pixels are square to within " << Num(b.aspect) << ")";
    *option = "focal_aspect_max";
  } else if (k.cx < -0.5 - b.margin * width || k.cx > width - 0.5 + b.margin * width ||
             k.cy < -0.5 - b.margin * height || k.cy > height - 0.5 + b.margin * height) {
    why << "the principal point (" << Num(k.cx) << ", " << Num(k.cy) << ") is outside the image";
    *option = "principal_point_margin";
  }
  return why.str();
}

std::string Values(const Camera& k) { return Num(k.fx) + "," + Num(k.fy) + "," + Num(k.cx) + "," + Num(k.cy); }

// The likely mistake behind intrinsics that do not fit: the first reading of the four numbers that does fit, said
// as the fix ("they look normalised: …"); empty when none does.
std::string LikelyMistake(const Camera& k, int width, int height, const Bounds& b) {
  struct Reading {
    const char* what;
    Camera camera;
  };
  std::vector<Reading> readings;
  if (std::max(k.fx, k.fy) < 10 && std::abs(k.cx) <= 2 && std::abs(k.cy) <= 2) {
    // Normalised by the width and height, or the focal lengths by the long side (square pixels either way).
    const double side = std::max(width, height);
    readings.push_back({"they look normalised: multiply fx and cx by the width and fy and cy by the height",
                        Camera{k.fx * width, k.fy * height, k.cx * width - 0.5, k.cy * height - 0.5}});
    readings.push_back(
        {"they look normalised: multiply fx and fy by the long side, cx by the width and cy by the height",
         Camera{k.fx * side, k.fy * side, k.cx * width - 0.5, k.cy * height - 0.5}});
  }
  readings.push_back({"they look like cx,cy,fx,fy: give fx,fy,cx,cy", Camera{k.cx, k.cy, k.fx, k.fy}});
  readings.push_back({"they look like fx,cx,fy,cy: give fx,fy,cx,cy", Camera{k.fx, k.cx, k.fy, k.cy}});
  readings.push_back(
      {"they look like the intrinsics of the photo turned by 90 degrees (its stored orientation, before "
       "the EXIF rotation?): swap fx with fy and cx with cy",
       Camera{k.fy, k.fx, k.cy, k.cx}});
  // The principal point at the centre of an image s times this one's size: intrinsics of another resolution.
  const double s = ((k.cx + 0.5) / (0.5 * width) + (k.cy + 0.5) / (0.5 * height)) / 2;
  std::string other_size;
  if (std::isfinite(s) && s > 0 && std::abs(s - 1) > 0.05) {
    other_size = "they look like the intrinsics of a " + std::to_string(std::lround(width * s)) + "x" +
                 std::to_string(std::lround(height * s)) +
                 " image (a resized photo keeps its old intrinsics): scale them by " + Num(1 / s);
    readings.push_back(
        {other_size.c_str(), Camera{k.fx / s, k.fy / s, (k.cx + 0.5) / s - 0.5, (k.cy + 0.5) / s - 0.5}});
  }
  for (const Reading& r : readings) {
    std::string unused;
    if (Misfit(r.camera, width, height, b, &unused).empty()) return std::string(r.what) + ": " + Values(r.camera);
  }
  return "";
}

}  // namespace

void ApplyDepthUnit(DepthUnit unit, DepthMap* d) {
  if (d->storage != DepthStorage::kInteger) return;
  const float f = static_cast<float>(UnitMetres(unit) / 1e-3);
  if (f != 1.f)
    for (float& v : d->data) v *= f;
  d->storage = DepthStorage::kMetres;
}

DepthMap CheckProvidedDepth(DepthMap d, int image_width, int image_height, int work_width, int work_height,
                            const InputOptions& o, const std::string& frame, InputNotes* notes) {
  if (d.empty()) return d;
  const bool integer = d.storage == DepthStorage::kInteger;
  ApplyDepthUnit(o.depth_unit, &d);
  const std::string name = Named(frame, d);
  if (image_width > 0 && image_height > 0 && (d.width != work_width || d.height != work_height)) {
    // Same aspect ratio within 1 %: another resolution of the same view. Products in 64 bits: sizes come from files.
    const double cross = static_cast<double>(d.width) * image_height,
                 other = static_cast<double>(image_width) * d.height;
    FREELOC_CHECK(
        std::abs(cross - other) <= 0.01 * other,
        name << ": the depth map is " << d.width << "x" << d.height << " but the photo is " << image_width << "x"
             << image_height << " as displayed"
             << (static_cast<int64_t>(d.width) * image_width == static_cast<int64_t>(d.height) * image_height ||
                         (d.width == image_height && d.height == image_width)
                     ? " (transposed, or in the photo's stored orientation before its EXIF rotation?)"
                     : "")
             << "; give the depth map in the photo's displayed orientation, at its size or any size of "
                "the same aspect ratio");
    const std::string from = std::to_string(d.width) + "x" + std::to_string(d.height);
    const bool photo_size = d.width == image_width && d.height == image_height;
    d = Resample(d, work_width, work_height);
    if (notes && !photo_size)
      notes->Add(frame + ": resampled from " + from + " to " + std::to_string(image_width) + "x" +
                     std::to_string(image_height),
                 kResampledDepthFactor);
  }
  double median = 0, lo = 0, hi = 0;
  if (!DepthStatistics(d, &median, &lo, &hi)) return d;  // no valid pixel: the solvers say no depth
  const InputOptions defaults;
  const bool near = median < o.depth_median_min_m;
  const bool far = median > o.depth_median_max_m;
  if (near || far) {
    std::ostringstream m;
    m << name << ": the valid depths' median is " << Num(median) << " m ("
      << (near ? "below " + Num(o.depth_median_min_m) : "above " + Num(o.depth_median_max_m)) << " m)";
    if (integer) {
      const double to_raw = 1 / UnitMetres(o.depth_unit);
      const DepthUnit likely = LikelyUnit(median * to_raw, o.depth_unit);
      m << ": its values " << Num(lo * to_raw) << "–" << Num(hi * to_raw) << " (median " << Num(median * to_raw)
        << ") read as " << UnitWord(o.depth_unit) << "; " << UnitWord(likely)
        << " stored as integers? set depth_unit=" << ToString(likely);
      const std::string bound =
          near ? "depth_median_min_m=" + Num(median / 2) : "depth_median_max_m=" + Num(median * 2);
      m << " (a scene really that " << (near ? "close" : "far") << ": set " << bound << ")";
      throw InputFixError(m.str(), "depth_unit", ToString(likely));
    }
    m << ": float depth is metres";
    if (far) m << "; values in millimetres? divide them by 1000 (or hand them in as uint16 millimetres)";
    const std::string field = near ? "depth_median_min_m" : "depth_median_max_m";
    const std::string value = Num(near ? median / 2 : median * 2);
    m << "; a scene really that " << (near ? "close" : "far") << ": set " << field << "=" << value;
    throw InputFixError(m.str(), field, value);
  }
  if (notes && (median < defaults.depth_median_min_m || median > defaults.depth_median_max_m))
    notes->Add(frame + ": median depth " + Num(median) + " m, accepted only by a loosened bound", kLoosenedBoundFactor);
  return d;
}

void CheckIntrinsics(const Camera& k, int width, int height, const InputOptions& o, const std::string& what,
                     InputNotes* notes) {
  k.Validate(what);
  if (width <= 0 || height <= 0) return;
  const Bounds given(o), defaults{InputOptions()};
  std::string option;
  const std::string why = Misfit(k, width, height, given, &option);
  if (why.empty()) {
    std::string unused;
    const std::string by_default = Misfit(k, width, height, defaults, &unused);
    if (notes && !by_default.empty())
      notes->Add(what + ": " + by_default + ", accepted only by a loosened bound", kLoosenedBoundFactor);
    return;
  }
  const std::string mistake = LikelyMistake(k, width, height, defaults);
  std::ostringstream m;
  m << what << " " << Values(k) << " (fx,fy,cx,cy) do not fit the " << width << "x" << height << " photo: " << why
    << "; " << (mistake.empty() ? "give fx,fy,cx,cy in pixels of this photo as displayed" : mistake);
  if (option.empty()) FREELOC_THROW(m.str());
  m << "; if they are right, loosen the bound: set " << option << "=…";
  throw InputFixError(m.str(), option, "…");
}

void CheckDepthAgreement(const Correspondences& c, const Camera& k_ref, const Camera& k_query, const DepthMap& d_ref,
                         const DepthMap& d_query, pose::PoseEstimate* r) {
  if (d_ref.empty() || d_query.empty() || !(r->ok() || r->weak()) || r->inlier_mask.size() != c.size()) return;
  std::vector<double> ratio;
  for (size_t i = 0; i < c.size(); ++i) {
    if (!r->inlier_mask[i]) continue;
    const double zr = geometry::BilinearDepth(d_ref, c.ref[i].x(), c.ref[i].y());
    const double zq = geometry::BilinearDepth(d_query, c.query[i].x(), c.query[i].y());
    if (!(zr > 0) || !(zq > 0)) continue;
    const double predicted = (r->query_from_ref * (zr * k_ref.Unproject(c.ref[i].x(), c.ref[i].y()))).z();
    if (predicted > 0) ratio.push_back(zq / predicted);
  }
  if (ratio.size() < 10) return;
  auto mid = ratio.begin() + static_cast<std::ptrdiff_t>(ratio.size() / 2);
  std::nth_element(ratio.begin(), mid, ratio.end());
  const double m = *mid;
  if (m <= kDepthAgreementRatio && m >= 1 / kDepthAgreementRatio) return;
  r->status = pose::Status::kScaleNoConsensus;
  r->message = "the depth maps disagree: at " + std::to_string(ratio.size()) + " inliers the query depth" +
               (d_query.source.empty() ? "" : " (" + d_query.source + ")") + " is " + Num(m) +
               " times what the reference depth" + (d_ref.source.empty() ? "" : " (" + d_ref.source + ")") +
               " and the pose predict; give both in the same unit (depth_unit), each map with its own photo";
}

}  // namespace freeloc::inputs

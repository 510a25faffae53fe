#include "freeloc/pose/window_fusion.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "freeloc/core/error.h"
#include "freeloc/geometry/window_scale.h"
#include "freeloc/pose/confidence.h"

namespace freeloc::pose {

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Device poses against the images, per frame: a relation agrees when the rotations are within 1°, the translations'
// directions within 8° or 2 cm across (when either is longer than 2 cm: an essential matrix over a few centimetres
// is that uncertain in its direction) and, with a metric image relation, their lengths within a factor 1.6 (the
// image relation's scale is a depth map's: only gross disagreement shows).
constexpr double kAgreeRotationDeg = 1.0, kAgreeDirectionDeg = 8, kAgreeLateralM = 0.02, kAgreeMinLengthM = 0.02,
                 kAgreeLengthRatio = 1.6;
// A window trusts its device poses when at least two frames could be compared and 60 % of them agree.
constexpr double kTrustFraction = 0.6;
// Relative scale uncertainty of a tracker's metric baseline (visual-inertial odometry drifts by a few per cent), and
// the rotation and position uncertainty of one of its relations within a window.
constexpr double kTrackerScaleSigma = 0.02;
constexpr double kDeviceRotationSigmaDeg = 0.3, kDevicePositionSigmaM = 0.005;
// Floor of a frame's own predicted rotation error (a vote is never taken as exact).
constexpr double kMinRotationSigmaDeg = 0.01;
// The frames' own-map distances of good depth maps scatter by the relations' noise (about 1 %); beyond 3 % the maps
// themselves are off, each by its own amount.
constexpr double kConsistentMapSpread = 0.03;
// Floor of any relative distance uncertainty, and of one ray's angular noise.
constexpr double kMinRelSigma = 0.01;
constexpr double kMinRaySigmaRad = 0.1 * kDeg;

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

// How a frame's device relation compares with its image relation.
bool DeviceAgrees(const FrameEvidence& f) {
  if (RotationAngleDeg(f.device.rotation, f.image_relation.rotation) > kAgreeRotationDeg) return false;
  const Eigen::Vector3d& td = f.device.translation;
  const Eigen::Vector3d& ti = f.image_relation.translation;
  if (std::max(td.norm(), f.image_relation_metric ? ti.norm() : 0.0) < kAgreeMinLengthM) return true;
  if (td.norm() < 1e-9 || ti.norm() < 1e-9) return false;
  const double c = std::clamp(td.normalized().dot(ti.normalized()), -1.0, 1.0);
  const double allowed = std::max(kAgreeDirectionDeg * kDeg, std::asin(std::min(1.0, kAgreeLateralM / td.norm())));
  if (std::acos(c) > allowed) return false;
  if (!f.image_relation_metric) return true;
  const double ratio = td.norm() / ti.norm();
  return ratio <= kAgreeLengthRatio && ratio >= 1 / kAgreeLengthRatio;
}

struct Vote {
  size_t k = 0;                                  // index into the window
  Eigen::Quaterniond q_from_r;                   // the evaluated frame's rotation as this frame votes it
  bool metric_relation = false;                  // c is in metres
  Eigen::Vector3d c = Eigen::Vector3d::Zero();   // this frame's centre in the evaluated frame's coordinates
  Eigen::Vector3d d = Eigen::Vector3d::UnitZ();  // unit ray from c towards the reference camera's centre
  double range = 0;                              // metric: |t| of this frame's own answer (along d), else 0
  double rel_sigma = 0;                          // its predicted relative error
  double weight = 1;          // 1 / variance of its rotation and ray (degrees²): its own and its relation's
  double position_sigma = 0;  // its relation's position error (metres)
  double ref_anchor = 0, query_anchor = 0;  // its |t| anchored by the reference's / its own depth map alone (0: none)
};

Eigen::Quaterniond MeanRotation(const std::vector<Eigen::Quaterniond>& qs, const std::vector<double>& weights) {
  Eigen::Vector4d acc = Eigen::Vector4d::Zero();
  for (size_t i = 0; i < qs.size(); ++i)
    acc += weights[i] * (qs[i].coeffs().dot(qs[0].coeffs()) < 0 ? -1.0 : 1.0) * qs[i].coeffs();
  Eigen::Quaterniond m;
  m.coeffs() = acc.normalized();
  return m;
}

// The point closest to the rays (c_j, d_j) in the least-squares sense, its rays' angular noise (estimated from the
// residuals, floored) and the relative standard deviation of its distance from the origin. False when the rays do
// not meet in front of their origins.
bool Triangulate(const std::vector<Eigen::Vector3d>& c, const std::vector<Eigen::Vector3d>& d, Eigen::Vector3d* p,
                 double* rel_sigma, double* ray_sigma) {
  const size_t n = c.size();
  if (n < 2) return false;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (size_t j = 0; j < n; ++j) {
    const Eigen::Matrix3d A = Eigen::Matrix3d::Identity() - d[j] * d[j].transpose();
    H += A;
    b += A * c[j];
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(H);
  if (eig.eigenvalues()(0) < 1e-14) return false;  // parallel rays from one line: no distance
  *p = H.ldlt().solve(b);
  if (!p->allFinite() || p->norm() < 1e-6) return false;
  double ss = 0;
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  for (size_t j = 0; j < n; ++j) {
    const Eigen::Vector3d v = *p - c[j];
    if (v.dot(d[j]) <= 0) return false;  // behind this frame
    const Eigen::Matrix3d A = Eigen::Matrix3d::Identity() - d[j] * d[j].transpose();
    ss += (A * v).squaredNorm() / v.squaredNorm();
    info += A / v.squaredNorm();
  }
  *ray_sigma = std::max(kMinRaySigmaRad, std::sqrt(ss / std::max<double>(1, 2.0 * n - 3)));
  const Eigen::Vector3d u = p->normalized();
  const double var = u.dot(info.ldlt().solve(u)) * (*ray_sigma) * (*ray_sigma);
  if (!(var >= 0) || !std::isfinite(var)) return false;
  *rel_sigma = std::sqrt(var) / p->norm();
  return true;
}

double Miss(const Eigen::Vector3d& p, const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  return std::acos(std::clamp((p - c).normalized().dot(d), -1.0, 1.0));
}

// Triangulate on the rays that agree: every pair of rays proposes a point, the one that most rays pass within 3°
// wins (ties: the smaller total miss), then the least-squares point of those rays, whose misses decide once more
// (3° or three times the rays' noise). A ray whose frame answered wrongly cannot drag the rig's point away.
bool RobustTriangulate(const std::vector<Eigen::Vector3d>& c, const std::vector<Eigen::Vector3d>& d, Eigen::Vector3d* p,
                       double* rel_sigma, double* ray_sigma) {
  const size_t n = c.size();
  if (n < 2) return false;
  constexpr double kTau = 3 * kDeg;
  size_t best_count = 0;
  double best_miss = 1e300;
  Eigen::Vector3d best;
  for (size_t a = 0; a < n; ++a)
    for (size_t b = a + 1; b < n; ++b) {
      Eigen::Vector3d x;
      double rs = 0, ss = 0;
      if (!Triangulate({c[a], c[b]}, {d[a], d[b]}, &x, &rs, &ss)) continue;
      size_t count = 0;
      double total = 0;
      for (size_t j = 0; j < n; ++j) {
        const double m = Miss(x, c[j], d[j]);
        if (m <= kTau) ++count, total += m;
      }
      if (count > best_count || (count == best_count && total < best_miss))
        best_count = count, best_miss = total, best = x;
    }
  if (best_count < 2) return false;
  for (int round = 0; round < 2; ++round) {
    std::vector<Eigen::Vector3d> ci, di;
    for (size_t j = 0; j < n; ++j)
      if (Miss(best, c[j], d[j]) <= std::max(kTau, round ? 3 * *ray_sigma : 0.0)) {
        ci.push_back(c[j]);
        di.push_back(d[j]);
      }
    if (!Triangulate(ci, di, p, rel_sigma, ray_sigma)) return false;
    best = *p;
  }
  return true;
}

geometry::AnchoredLength Anchored(bool has, double log_length, double se) {
  geometry::AnchoredLength a;
  a.has = has;
  a.log_length = log_length;
  a.se = se;
  return a;
}

// The window's distance from every depth map's anchoring at once (geometry/window_scale.h): the kept votes' rays,
// their metric image relations' directions, each frame's two anchorings of its answer and of its relation.
geometry::WindowScaleResult JointScale(const std::vector<FrameEvidence>& frames, const std::vector<Vote>& kept,
                                       size_t qi, double ray_floor_rad) {
  const auto self = std::find_if(kept.begin(), kept.end(), [&](const Vote& v) { return v.k == qi; });
  if (self == kept.end() || !frames[qi].to_ref.metric()) return {};
  const auto ray_sigma = [&](const Vote& v) { return std::max(ray_floor_rad, kDeg / std::sqrt(v.weight)); };
  geometry::WindowScaleInput in;
  const geometry::ScaleAnchors& qa = frames[qi].anchors;
  in.ray = self->d;
  in.ray_sigma_rad = ray_sigma(*self);
  in.to_ref_by_ref = Anchored(qa.kept_ref >= 3, qa.log_ref, qa.se_ref);
  in.to_ref_by_own = Anchored(qa.kept_query >= 3, qa.log_query, qa.se_query);
  for (const Vote& v : kept) {
    const FrameEvidence& f = frames[v.k];
    if (v.k == qi || !v.metric_relation || !f.has_image_relation || v.c.norm() < 1e-6) continue;
    geometry::WindowFrameGeometry g;
    g.ray = v.d;
    g.ray_sigma_rad = ray_sigma(v);
    g.baseline = v.c;
    g.baseline_sigma_rad = std::clamp(v.position_sigma / v.c.norm(), 0.5 * kDeg, 20 * kDeg);
    const geometry::ScaleAnchors& a = f.anchors;
    const bool metric = f.to_ref.metric();
    g.to_ref_by_ref = Anchored(metric && a.kept_ref >= 3, a.log_ref, a.se_ref);
    g.to_ref_by_own = Anchored(metric && a.kept_query >= 3, a.log_query, a.se_query);
    const geometry::ScaleAnchors& ra = f.relation_anchors;
    g.relation_by_q = Anchored(ra.kept_ref >= 3, ra.log_ref, ra.se_ref);
    g.relation_by_own = Anchored(ra.kept_query >= 3, ra.log_query, ra.se_query);
    in.frames.push_back(g);
  }
  return geometry::EstimateWindowScale(in);
}

// ---------------------------------------------------------------------------------------------------------------
// Step 1, evidence: the device poses (off, absent, refused — the evaluated frame's line must be the identity — or
// checked against the images) and per frame the relation that ties it to the evaluated frame, as a vote.

struct DeviceDecision {
  bool ok = false;           // the window's device poses are used
  std::vector<char> agrees;  // per frame: its device relation agrees with its image relation
};

DeviceDecision DecideDevicePoses(const std::vector<FrameEvidence>& frames, DevicePoseUse use, WindowSummary* w) {
  const size_t n = frames.size(), qi = n - 1;
  DeviceDecision d;
  int with_device = 0, comparable = 0, agree = 0;
  d.agrees.assign(n, 0);
  for (size_t k = 0; k + 1 < n; ++k) {
    if (!frames[k].has_device) continue;
    ++with_device;
    if (!frames[k].has_image_relation) continue;
    ++comparable;
    d.agrees[k] = DeviceAgrees(frames[k]);
    agree += d.agrees[k];
  }
  const std::string tally =
      std::to_string(agree) + " of " + std::to_string(comparable) + " frames agree with the images";
  if (use == DevicePoseUse::kIgnore) {
    w->device = "off";
  } else if (with_device == 0) {
    w->device = "absent";
  } else if (frames[qi].has_device &&
             (RotationAngleDeg(frames[qi].device.rotation, Eigen::Quaterniond::Identity()) > 1e-7 ||
              frames[qi].device.translation.norm() > 1e-9)) {
    w->device = "ignored (the evaluated frame's line is not the identity)";
  } else if (use == DevicePoseUse::kUse) {
    d.ok = true;
    w->device = "used";
  } else if (comparable < 2) {
    w->device = "ignored (too few frames to check them against the images)";
  } else if (agree >= kTrustFraction * comparable) {
    d.ok = true;
    w->device = "used (" + tally + ")";
  } else {
    w->device = "ignored (" + tally + ")";
  }
  return d;
}

// Every answered frame with a relation votes for the evaluated frame's pose.
std::vector<Vote> CollectVotes(const std::vector<FrameEvidence>& frames, DevicePoseUse use, const DeviceDecision& dev,
                               WindowSummary* w) {
  const size_t n = frames.size(), qi = n - 1;
  std::vector<Vote> votes;
  for (size_t k = 0; k < n; ++k) {
    const FrameEvidence& f = frames[k];
    WindowVote& wv = w->votes[k];
    Rigid3d rel;  // frame_from_query
    bool metric_rel = true;
    double rel_rot_deg = 0, rel_pos_m = 0;  // the relation's own uncertainty
    if (k == qi) {
      wv.relation = "self";
    } else if (dev.ok && f.has_device && (use == DevicePoseUse::kUse || dev.agrees[k] || !f.has_image_relation)) {
      // The tracker's relation where it agrees with the images: over a few centimetres it is the more precise
      // (millimetres of drift against an essential matrix's degrees), and metric.
      rel = f.device;
      rel_rot_deg = kDeviceRotationSigmaDeg;
      rel_pos_m = kDevicePositionSigmaM;
      wv.relation = "device";
    } else if (f.has_image_relation) {
      rel = f.image_relation;
      metric_rel = f.image_relation_metric;
      rel_rot_deg = f.image_relation_rot_sigma_deg;
      rel_pos_m = f.image_relation_position_sigma_m;
      wv.relation = "images";
    } else {
      continue;
    }
    if (!f.to_ref.ok()) continue;
    const Rigid3d& jr = f.to_ref.query_from_ref;  // frame_from_ref
    const Eigen::Quaterniond q_from_j = rel.rotation.conjugate();
    Vote v;
    v.k = k;
    v.q_from_r = (q_from_j * jr.rotation).normalized();
    v.metric_relation = metric_rel;
    v.c = rel.Center();
    const double tn = jr.translation.norm();
    if (tn < 1e-12) continue;
    v.d = q_from_j * (jr.translation / tn);
    if (f.to_ref.metric()) {
      v.range = tn;
      v.rel_sigma = f.to_ref.predicted_translation_m / tn;
      if (f.anchors.kept_ref >= 3) v.ref_anchor = std::exp(f.anchors.log_ref);
      if (f.anchors.kept_query >= 3) v.query_anchor = std::exp(f.anchors.log_query);
    }
    // Its rotation and ray errors: its own answer's, plus its relation's (a position error seen from the reference
    // camera's distance).
    const double own = std::max(kMinRotationSigmaDeg, f.to_ref.predicted_rotation_deg);
    const double pos_deg = rel_pos_m / std::max(0.1, tn) / kDeg;
    v.weight = 1 / (own * own + rel_rot_deg * rel_rot_deg + pos_deg * pos_deg);
    v.position_sigma = rel_pos_m;
    votes.push_back(v);
  }
  return votes;
}

// ---------------------------------------------------------------------------------------------------------------
// Step 2, shape: the rotation — the medoid of the votes, then the mean of those near it (the votes kept).

Eigen::Quaterniond FuseRotation(const std::vector<Vote>& votes, std::vector<Vote>* kept) {
  const size_t nv = votes.size();
  size_t medoid = 0;
  double best = 1e300;
  for (size_t a = 0; a < nv; ++a) {
    double s = 0;
    for (size_t b = 0; b < nv; ++b) s += std::min(10.0, RotationAngleDeg(votes[a].q_from_r, votes[b].q_from_r));
    if (s < best) best = s, medoid = a;
  }
  std::vector<double> dev;
  for (const Vote& v : votes) dev.push_back(RotationAngleDeg(v.q_from_r, votes[medoid].q_from_r));
  const double keep_deg = std::max(2.0, 3.0 * Median(dev));
  std::vector<Eigen::Quaterniond> qs;
  std::vector<double> qw;
  for (size_t a = 0; a < nv; ++a)
    if (dev[a] <= keep_deg) {
      kept->push_back(votes[a]);
      qs.push_back(votes[a].q_from_r);
      qw.push_back(votes[a].weight);
    }
  return MeanRotation(qs, qw);
}

// ---------------------------------------------------------------------------------------------------------------
// Step 3, scale: the distance from the depth maps (each metric frame's answer placed on its ray), from the rig (the
// rays with metric origins triangulated) and from all maps at once, fused in log space.

struct Distance {
  bool metric = false;
  double log_dist = 0, log_sigma = 0;
  double ray_sigma = kMinRaySigmaRad;  // the rays' angular noise (the rig's triangulation measures it)
  bool good_maps = false;              // the depth maps are good (within kConsistentMapSpread)
};

// The depth maps' distance: the evaluated frame's own answer when it is metric and not far from the others (the
// median otherwise); with query maps that scatter beyond what good maps do, their mean weighed against the
// reference map's anchoring. Fills w->depth_distance_m and each vote's distance; returns the log-distance's
// uncertainty (`own_map_spread`: the frames' own-map distances' spread, −1 when too few to say).
struct DepthDistance {
  std::vector<double> log_depth;  // per metric vote with a range
  double sigma0 = 0;
  double own_map_spread = -1;
};

DepthDistance DepthMapsDistance(const std::vector<Vote>& kept, size_t qi, WindowSummary* w) {
  DepthDistance dd;
  std::vector<double> rel_pred;
  for (const Vote& v : kept) {
    if (!v.metric_relation || !(v.range > 0)) continue;
    const double rho = (v.c + v.range * v.d).norm();
    w->votes[v.k].distance_m = rho;
    dd.log_depth.push_back(std::log(rho));
    rel_pred.push_back(v.rel_sigma);
  }
  if (dd.log_depth.empty()) return dd;
  const std::vector<double>& log_depth = dd.log_depth;
  std::vector<double> absdev;
  const double med = Median(log_depth);
  for (double l : log_depth) absdev.push_back(std::abs(l - med));
  const double spread = 1.4826 * Median(absdev);
  dd.sigma0 = std::max({Median(rel_pred), spread, kMinRelSigma});
  // Every frame's depth answer leans on the same reference depth map, so their errors are largely shared and
  // averaging them gains little; the evaluated frame's own answer carries no relation error.
  const bool self_metric = !kept.empty() && kept.back().k == qi && kept.back().range > 0 && kept.back().metric_relation;
  const double self_log = self_metric ? log_depth.back() : med;
  double dep_log = std::abs(self_log - med) <= std::max(3 * spread, 0.05) ? self_log : med;
  // The query depth maps are the window's independent evidence: each frame's distance anchored by its own map
  // alone. Their spread measures how good a map of this kind is; when they scatter beyond what good maps do (a
  // monocular map's scale is off by its own amount in every frame), their mean — an error shrinking with the
  // number of frames — is weighed against the reference map's anchoring (assumed as good as one query map).
  std::vector<double> lq, lever;  // lever: how much of a relation's scale error reaches the distance (|c|/ρ)
  for (const Vote& v : kept)
    if (v.metric_relation && v.query_anchor > 0) {
      const double rho = (v.c + v.query_anchor * v.d).norm();
      lq.push_back(std::log(rho));
      lever.push_back(v.c.norm() / rho);
    }
  if (lq.size() >= 3) {
    std::vector<double> dq;
    const double mq = Median(lq);
    for (double l : lq) dq.push_back(std::abs(l - mq));
    const double per_map = 1.4826 * Median(dq);
    dd.own_map_spread = per_map;
    if (per_map > kConsistentMapSpread) {
      // Each frame's own-map distance: its map's error, plus its relation's scale error (a depth map's too) times
      // its lever; frames far off the median are left out.
      double sw = 0, swl = 0;
      for (size_t i = 0; i < lq.size(); ++i) {
        if (dq[i] > 3 * per_map) continue;
        const double var = per_map * per_map * (1 + lever[i] * lever[i]);
        sw += 1 / var, swl += lq[i] / var;
      }
      const Vote* self = !kept.empty() && kept.back().k == qi ? &kept.back() : nullptr;
      const double lr = self && self->ref_anchor > 0 ? std::log(self->ref_anchor) : dep_log;
      const double vr = per_map * per_map;
      dep_log = (lr / vr + swl) / (1 / vr + sw);
      dd.sigma0 = std::max(kMinRelSigma, 1 / std::sqrt(1 / vr + sw));
    }
  }
  w->depth_distance_m = std::exp(dep_log);
  return dd;
}

// How good the depth maps are — two measures of one map's error, with different noise: the frames' own-map distances
// placed through their relations (DepthMapsDistance), and each frame's two anchorings of its own |t| (the reference
// map's and its own: both maps' errors, whatever ties the frame to the others; a robust spread over √2). The maps
// are good when either is within 3 % — a monocular map fails both by far.
bool GoodMaps(const std::vector<FrameEvidence>& frames, double own_map_spread) {
  std::vector<double> halves_apart;
  for (const FrameEvidence& f : frames)
    if (f.to_ref.metric() && f.anchors.kept_ref >= 3 && f.anchors.kept_query >= 3)
      halves_apart.push_back(std::abs(f.anchors.log_ref - f.anchors.log_query));
  const double halves_spread = halves_apart.size() >= 3 ? 1.4826 * Median(halves_apart) / std::sqrt(2.0) : -1;
  return (own_map_spread >= 0 && own_map_spread <= kConsistentMapSpread) ||
         (halves_spread >= 0 && halves_spread <= kConsistentMapSpread);
}

// The rig: the rays with metric origins triangulated; its relative distance error includes the origins' (an origin
// off by δ across the rays moves the point along them by about δ·distance/baseline, the baseline being the rig's
// extent across the rays). False when it does not exist or its distance is not known to within 50 %.
struct Rig {
  bool ok = false, device = false;  // device: a tracker's relation is among its origins
  Eigen::Vector3d point;
  double rel = 0;
};

Rig TriangulateRig(const std::vector<Vote>& kept, size_t qi, const WindowSummary& w, double* ray_sigma) {
  Rig rig;
  std::vector<Eigen::Vector3d> rc, rd;
  std::vector<double> origin_sigma;  // the relations' position errors (the evaluated frame's own: none)
  for (const Vote& v : kept) {
    if (!v.metric_relation) continue;
    rc.push_back(v.c);
    rd.push_back(v.d);
    if (v.k != qi) origin_sigma.push_back(v.position_sigma);
    rig.device = rig.device || w.votes[v.k].relation == "device";
  }
  rig.ok = RobustTriangulate(rc, rd, &rig.point, &rig.rel, ray_sigma);
  if (rig.ok) {
    const Eigen::Vector3d u = rig.point.normalized();
    double extent = 0;
    for (const auto& c : rc) extent = std::max(extent, (c - u * u.dot(c)).norm());
    rig.rel = extent > 0 ? std::hypot(rig.rel, Median(origin_sigma) / extent) : 1.0;
  }
  if (rig.ok && rig.rel > 0.5) rig.ok = false;
  return rig;
}

// The depth maps' distance and the rig's together. The rig's baseline is the tracker's (a few per cent of scale
// drift on top) or the images' (the relations' own predicted errors, already in its rel).
void CombineWithRig(const Rig& rig, const DepthDistance& dd, Distance* d, WindowSummary* w) {
  const double s_rig = std::hypot(rig.rel, rig.device ? kTrackerScaleSigma : 0);
  w->rig_distance_m = rig.point.norm();
  const double l_rig = std::log(rig.point.norm());
  d->metric = true;
  if (dd.log_depth.empty()) {
    d->log_dist = l_rig, d->log_sigma = s_rig;
    w->scale = rig.device ? "tracker" : "images";
    return;
  }
  const double dep_sigma0 = dd.sigma0;
  const double l_dep = std::log(w->depth_distance_m);
  const double D = l_dep - l_rig;
  double s_dep = dep_sigma0, s_r = s_rig;
  if (rig.device) {
    // An independent metric baseline: a disagreement beyond twice its uncertainty is the depth maps' error.
    s_dep = std::sqrt(std::max(dep_sigma0 * dep_sigma0, D * D - 4 * s_rig * s_rig));
  } else if (D * D > 4 * (dep_sigma0 * dep_sigma0 + s_rig * s_rig)) {
    // Two depth-made estimates that disagree: neither can be preferred, each is charged half the disagreement.
    s_dep = std::sqrt(dep_sigma0 * dep_sigma0 + 0.5 * D * D);
    s_r = std::sqrt(s_rig * s_rig + 0.5 * D * D);
  }
  const double wd = 1 / (s_dep * s_dep), wr = 1 / (s_r * s_r);
  if (d->good_maps || (dep_sigma0 <= s_rig && D * D <= 4 * (dep_sigma0 * dep_sigma0 + s_rig * s_rig))) {
    // Good maps, or maps that predict a smaller error than the rig's and that the rig does not contradict: the
    // depth distance is already the better one, and stands (a tracker drifts by per cents; good maps do not).
    d->log_dist = l_dep, d->log_sigma = dep_sigma0;
    w->scale = std::string("depth (") + (rig.device ? "tracker" : "images") + " agrees)";
  } else {
    d->log_dist = (wd * l_dep + wr * l_rig) / (wd + wr);
    d->log_sigma = 1 / std::sqrt(wd + wr);
    w->scale = std::string("depth+") + (rig.device ? "tracker" : "images");
  }
}

Distance FuseDistance(const std::vector<FrameEvidence>& frames, const std::vector<Vote>& kept, WindowSummary* w) {
  const size_t qi = frames.size() - 1;
  Distance d;
  const DepthDistance dd = DepthMapsDistance(kept, qi, w);
  const Rig rig = TriangulateRig(kept, qi, *w, &d.ray_sigma);
  d.good_maps = GoodMaps(frames, dd.own_map_spread);
  if (rig.ok) {
    CombineWithRig(rig, dd, &d, w);
  } else if (!dd.log_depth.empty()) {
    d.log_dist = std::log(w->depth_distance_m);
    d.log_sigma = dd.sigma0;
    w->scale = "depth";
    d.metric = true;
  }
  // Without a tracker every length is a depth map's: when the maps disagree, all of them at once, each map's error
  // shared by every length it anchors (geometry/window_scale.h).
  if (!rig.device) {
    const geometry::WindowScaleResult joint = JointScale(frames, kept, qi, d.ray_sigma);
    if (joint.ok && joint.map_sigma > kConsistentMapSpread) {
      d.log_dist = std::log(joint.distance);
      d.log_sigma = joint.log_sigma;
      w->depth_distance_m = joint.distance;
      w->scale = "maps (" + std::to_string(joint.maps) + " jointly)";
      d.metric = true;
    }
  }
  return d;
}

// ---------------------------------------------------------------------------------------------------------------
// Step 4, decision: the direction — the points of the rays at the fused distance, averaged (rays without metric
// origins: their directions), rays far off the mean left out — the pose and its predicted error; and whether it
// replaces the evaluated frame's own answer.

// The point of a ray at the fused distance from the evaluated frame (|c + λ·d| = dist; the ray's closest point when
// it does not reach that far).
Eigen::Vector3d PointAtDistance(const Vote& v, bool metric, double dist) {
  if (!(metric && v.metric_relation)) return dist * v.d;
  const double cd = v.c.dot(v.d), disc = cd * cd - v.c.squaredNorm() + dist * dist;
  const double lambda = disc > 0 ? -cd + std::sqrt(disc) : std::max(0.0, -cd);
  return v.c + lambda * v.d;
}

void Decide(const std::vector<FrameEvidence>& frames, const std::vector<Vote>& votes, const std::vector<Vote>& kept,
            const Eigen::Quaterniond& R, const Distance& d, FusedWindow* out) {
  const size_t qi = frames.size() - 1;
  WindowSummary& w = out->window;
  const double dist = d.metric ? std::exp(d.log_dist) : 1.0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Vote& v : kept) sum += v.weight * PointAtDistance(v, d.metric, dist).normalized();
  Eigen::Vector3d u = sum.normalized();
  std::vector<double> ang;
  for (const Vote& v : kept)
    ang.push_back(std::acos(std::clamp(PointAtDistance(v, d.metric, dist).normalized().dot(u), -1.0, 1.0)));
  const double keep_rad = std::max({3 * kDeg, 4 * d.ray_sigma, 3 * Median(ang)});
  sum.setZero();
  int used = 0;
  double ss_ang = 0, ss_rot = 0;
  std::vector<double> rot_pred;
  for (size_t a = 0; a < kept.size(); ++a) {
    if (ang[a] > keep_rad) continue;
    sum += kept[a].weight * PointAtDistance(kept[a], d.metric, dist).normalized();
    w.votes[kept[a].k].used = true;
    ++used;
    ss_ang += ang[a] * ang[a];
    const double rd_deg = RotationAngleDeg(kept[a].q_from_r, R);
    ss_rot += rd_deg * rd_deg;
    rot_pred.push_back(frames[kept[a].k].to_ref.predicted_rotation_deg);
  }
  for (const Vote& v : votes) w.votes[v.k].rotation_dev_deg = RotationAngleDeg(v.q_from_r, R);
  w.used = used;
  if (used == 0) return;
  u = sum.normalized();

  PoseEstimate& e = *out;
  e.status = d.metric ? Status::kOk : Status::kOkUnitTranslation;
  e.message.clear();
  e.query_from_ref = Rigid3d(R, dist * u);
  e.window_fused = true;
  const double nu = used;
  PredictedError pe;
  pe.rotation_deg = std::max({std::sqrt(ss_rot / nu) / std::sqrt(nu), Median(rot_pred) / std::sqrt(nu), 0.01});
  const double dir = std::max(std::sqrt(ss_ang / nu), d.ray_sigma) / std::sqrt(nu);
  pe.translation_m = std::max(1e-3, dist * std::sqrt(d.log_sigma * d.log_sigma + dir * dir));
  e.predicted_rotation_deg = pe.rotation_deg;
  e.predicted_translation_m = d.metric ? pe.translation_m : 0;
  e.confidence = d.metric ? ConfidenceFromPredictedError(pe) : used;
  // Good maps make the evaluated frame's own answer as good as they allow: the window replaces it only when it shows
  // that answer wrong — a move beyond twice its predicted error.
  const PoseEstimate& self = frames[qi].to_ref;
  if (d.good_maps && self.metric() && d.metric &&
      (e.query_from_ref.Center() - self.query_from_ref.Center()).norm() <= 2 * self.predicted_translation_m) {
    e = self;
    w.scale = "single frame (the window agrees)";
  }
}

}  // namespace

FusedWindow FuseWindow(const std::vector<FrameEvidence>& frames, DevicePoseUse use) {
  FREELOC_CHECK(!frames.empty(), "FuseWindow: no frames");
  const size_t n = frames.size();
  FusedWindow out;
  static_cast<PoseEstimate&>(out) = frames[n - 1].to_ref;
  WindowSummary& w = out.window;
  w.frames = static_cast<int>(n);
  w.votes.resize(n);
  for (size_t k = 0; k < n; ++k) {
    w.votes[k].frame = frames[k].name;
    w.votes[k].status = frames[k].to_ref.status;
  }
  const DeviceDecision device = DecideDevicePoses(frames, use, &w);
  const std::vector<Vote> votes = CollectVotes(frames, use, device, &w);
  if (votes.size() < 2) {
    // Nothing to fuse: the evaluated frame's own answer (or its failure), with the window's account.
    for (const Vote& v : votes) w.votes[v.k].used = true;
    w.used = static_cast<int>(votes.size());
    return out;
  }
  std::vector<Vote> kept;
  const Eigen::Quaterniond R = FuseRotation(votes, &kept);
  const Distance d = FuseDistance(frames, kept, &w);
  Decide(frames, votes, kept, R, d, &out);
  return out;
}

}  // namespace freeloc::pose

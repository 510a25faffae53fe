#include "freeloc/eval/metrics.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <sstream>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/io/pyparse.h"

namespace freeloc::eval {

const char* const kMetricNames[8] = {"Average Median Translation Error",
                                     "Average Median Rotation Error",
                                     "Average Median Reprojection Error",
                                     "Precision @ Pose Error < (25.0cm, 5deg)",
                                     "AUC @ Pose Error < (25.0cm, 5deg)",
                                     "Precision @ VCRE < 90px",
                                     "AUC @ VCRE < 90px",
                                     "Estimates for % of frames"};

std::array<double, 8> MetricValues(const Metrics& m) {
  return {m.avg_median_trans, m.avg_median_rot, m.avg_median_vcre, m.precision_pose,
          m.auc_pose,         m.precision_vcre, m.auc_vcre,        m.estimates_ratio};
}

size_t SceneRecord::estimates() const {
  size_t n = 0;
  for (const auto& f : frames) n += f.status == "submitted";
  return n;
}

namespace {

// Hamilton product, w-first (transforms3d qmult).
std::array<double, 4> QMult(const std::array<double, 4>& a, const std::array<double, 4>& b) {
  return {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3], a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] + a[2] * b[0] + a[3] * b[1] - a[1] * b[3], a[0] * b[3] + a[3] * b[0] + a[1] * b[2] - a[2] * b[1]};
}

double Norm4(const std::array<double, 4>& q) {
  return std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
}

// transforms3d quat2mat (allows non-unit quaternions).
Eigen::Matrix3d QuatToMat(const std::array<double, 4>& q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double nq = w * w + x * x + y * y + z * z;
  if (nq < 2.220446049250313e-16) return Eigen::Matrix3d::Identity();
  const double s = 2.0 / nq;
  const double X = x * s, Y = y * s, Z = z * s;
  const double wX = w * X, wY = w * Y, wZ = w * Z, xX = x * X, xY = x * Y, xZ = x * Z, yY = y * Y, yZ = y * Z,
               zZ = z * Z;
  Eigen::Matrix3d m;
  m << 1.0 - (yY + zZ), xY - wZ, xZ + wY, xY + wZ, 1.0 - (xX + zZ), yZ - wX, xZ - wY, yZ + wX, 1.0 - (xX + yY);
  return m;
}

// The 196 virtual points: x ∈ 0.3·(−3…3), y ∈ 0.3·(−1.5…1.5), z ∈ 1.8 + 0.3·(0…6).
const std::vector<Eigen::Vector3d>& VirtualGrid() {
  static const std::vector<Eigen::Vector3d> grid = [] {
    std::vector<Eigen::Vector3d> g;
    for (int iy = 0; iy < 4; ++iy)
      for (int ix = 0; ix < 7; ++ix)
        for (int iz = 0; iz < 7; ++iz) g.emplace_back((ix - 3.0) * 0.3, (iy - 1.5) * 0.3, iz * 0.3 + 1.8);
    return g;
  }();
  return grid;
}

Eigen::Vector2d ProjectClip(const Eigen::Vector3d& p, const double k[4], double w, double h) {
  const double u = k[0] * p.x() + k[2] * p.z();
  const double v = k[1] * p.y() + k[3] * p.z();
  return {std::clamp(u / p.z(), 0.0, w), std::clamp(v / p.z(), 0.0, h)};
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string ReadFile(const std::string& path, const std::string& what) {
  std::ifstream f(path, std::ios::binary);
  FREELOC_CHECK(f.good(), path << ": " << what << " not found; the ground-truth folder is incomplete");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

struct SceneIntrinsics {
  std::map<int64_t, std::array<float, 4>> k;
  double width = 0, height = 0;
};

// load_K(): lines containing '#' skipped; key int(path[-9:-4]); six numbers; float32 K; W, H of the last line.
SceneIntrinsics LoadIntrinsics(const std::string& path) {
  const std::string text = ReadFile(path, "intrinsics.txt");
  FREELOC_CHECK(io::py::IsValidUtf8(text), path << ": not UTF-8 text");
  SceneIntrinsics s;
  bool any = false;
  const auto lines = io::py::SplitLines(text);
  for (size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].find('#') != std::string::npos) continue;
    const std::string where = path + " line " + std::to_string(i + 1);
    const auto parts = io::py::SplitSpace(io::py::Strip(lines[i]));
    int64_t key;
    FREELOC_CHECK(io::py::FrameKey(parts[0], &key),
                  where << ": no frame number in '" << parts[0] << "' (expected seq1/frame_00000.jpg …)");
    FREELOC_CHECK(parts.size() == 7,
                  where << ": expected 'path fx fy cx cy width height' (7 fields), got " << parts.size());
    double v[6];
    for (int k = 0; k < 6; ++k)
      FREELOC_CHECK(io::py::ParseFloat(parts[k + 1], &v[k]), where << ": '" << parts[k + 1] << "' is not a number");
    s.k[key] = {static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]), static_cast<float>(v[3])};
    s.width = v[4];
    s.height = v[5];
    any = true;
  }
  FREELOC_CHECK(any, path << ": no intrinsics lines");
  return s;
}

}  // namespace

FrameErrors ComputeFrameErrors(const io::OfficialPose& gt, const io::OfficialPose& est, const std::array<float, 4>& kf,
                               double width, double height) {
  FrameErrors e;
  e.trans_err = (gt.t_c2w - est.t_c2w).norm();
  // quat_angle_error(label=q_est, pred=q_gt, 'sin'): q1 = pred/|pred|, q2 = label/|label|,
  // angle = asin(‖vec(q1 ⊗ qinverse(q2))‖)·2·180/π with qinverse = conj/|q| (transforms3d 0.4).
  std::array<double, 4> q1 = gt.q_c2w, q2 = est.q_c2w;
  const double n1 = Norm4(q1), n2 = Norm4(q2);
  for (auto& v : q1) v /= n1;
  for (auto& v : q2) v /= n2;
  const double n2b = Norm4(q2);
  const std::array<double, 4> q2inv = {q2[0] / n2b, -q2[1] / n2b, -q2[2] / n2b, -q2[3] / n2b};
  const auto s = QMult(q1, q2inv);
  e.rot_err = std::asin(std::sqrt(s[1] * s[1] + s[2] * s[2] + s[3] * s[3])) * 114.59155902616465;
  // VCRE: uv_gt = π(K, X); uv_est = π(K, (T_est_c2w)⁻¹·T_gt_c2w·X), both clipped to [0,W]×[0,H].
  const double k[4] = {kf[0], kf[1], kf[2], kf[3]};
  const Eigen::Matrix3d r_gt = QuatToMat(gt.q_c2w), r_est = QuatToMat(est.q_c2w);
  const Eigen::Matrix3d r_res = r_est.transpose() * r_gt;
  const Eigen::Vector3d t_res = r_est.transpose() * (gt.t_c2w - est.t_c2w);
  double sum = 0;
  for (const auto& x : VirtualGrid()) {
    const Eigen::Vector2d a = ProjectClip(x, k, width, height);
    const Eigen::Vector2d b = ProjectClip(r_res * x + t_res, k, width, height);
    sum += (a - b).norm();
  }
  e.vcre = sum / static_cast<double>(VirtualGrid().size());
  return e;
}

double PrecisionRecallAuc(const std::vector<double>& conf, const std::vector<bool>& accepted, int64_t failures) {
  const size_t n = conf.size();
  if (n == 0) return 0.0;
  std::vector<size_t> idx(n);
  std::iota(idx.begin(), idx.end(), 0);
  std::stable_sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return conf[a] > conf[b]; });
  // Points at the last index of each group of equal confidence (descending order).
  const float denom = static_cast<float>(static_cast<double>(n) + static_cast<double>(failures));
  std::vector<double> prec;
  std::vector<float> rec;
  int64_t cum_tp = 0;
  for (size_t i = 0; i < n; ++i) {
    cum_tp += accepted[idx[i]] ? 1 : 0;
    const bool last_of_group = (i + 1 == n) || conf[idx[i + 1]] != conf[idx[i]];
    if (!last_of_group) continue;
    const float r = static_cast<float>(i + 1);
    prec.push_back(static_cast<double>(cum_tp) / static_cast<double>(r));
    rec.push_back(r / denom);
  }
  // Reversed, with the (precision 1, recall 0) point appended; AUC = |Σ diff(rec) · prec[:-1]|, diffs in float32.
  // rec.searchsorted(rec[-1]): start at the first point whose recall equals the last one.
  size_t last = static_cast<size_t>(std::lower_bound(rec.begin(), rec.end(), rec.back()) - rec.begin());
  std::vector<double> p;
  std::vector<float> r;
  for (size_t k = last + 1; k-- > 0;) {
    p.push_back(prec[k]);
    r.push_back(rec[k]);
  }
  p.push_back(1.0);
  r.push_back(0.0f);
  double auc = 0;
  for (size_t k = 0; k + 1 < r.size(); ++k) {
    const float d = r[k + 1] - r[k];
    auc += static_cast<double>(d) * p[k];
  }
  return std::abs(auc);
}

Metrics Aggregate(const std::vector<SceneRecord>& scenes, const Thresholds& th) {
  Metrics m;
  std::vector<double> med_t, med_r, med_v, conf;
  std::vector<bool> acc_pose, acc_vcre;
  int64_t accepted_pose = 0, accepted_vcre = 0;
  for (const auto& s : scenes) {
    m.failures += s.failures;
    std::vector<double> t, r, v;
    for (const auto& f : s.frames) {
      if (f.status != "submitted") continue;
      t.push_back(f.err.trans_err);
      r.push_back(f.err.rot_err);
      v.push_back(f.err.vcre);
      conf.push_back(f.confidence);
      const bool ap = f.err.trans_err < th.translation_m && f.err.rot_err < th.rotation_deg;
      const bool av = f.err.vcre < th.vcre_px;
      acc_pose.push_back(ap);
      acc_vcre.push_back(av);
      accepted_pose += ap;
      accepted_vcre += av;
    }
    if (t.empty()) continue;
    med_t.push_back(Median(t));
    med_r.push_back(Median(r));
    med_v.push_back(Median(v));
    ++m.scenes_with_estimates;
  }
  size_t evaluated = 0;
  for (const auto& s : scenes) evaluated += s.frames.size();
  FREELOC_CHECK(evaluated > 0,
                "no scene has a frame to evaluate: the Multi Frame track evaluates linear positions 9, 19, … of seq1, "
                "so only scenes with 10 or more query frames; score these scenes on the single-frame track");
  FREELOC_CHECK(m.scenes_with_estimates > 0,
                "the submission has no valid pose estimate for any evaluated frame (the official evaluator prints no "
                "metrics); check the scene names (pose_sNNNNN.txt) and the frame names in the pose files");
  auto mean = [](const std::vector<double>& x) {
    double s = 0;
    for (double v : x) s += v;
    return s / static_cast<double>(x.size());
  };
  m.avg_median_trans = mean(med_t);
  m.avg_median_rot = mean(med_r);
  m.avg_median_vcre = mean(med_v);
  m.estimates = static_cast<int64_t>(conf.size());
  const double total = static_cast<double>(m.estimates + m.failures);
  m.precision_pose = static_cast<double>(accepted_pose) / total;
  m.precision_vcre = static_cast<double>(accepted_vcre) / total;
  m.auc_pose = PrecisionRecallAuc(conf, acc_pose, m.failures);
  m.auc_vcre = PrecisionRecallAuc(conf, acc_vcre, m.failures);
  m.estimates_ratio = static_cast<double>(m.estimates) / total;
  return m;
}

std::vector<int64_t> EvaluatedKeys(const io::OfficialPoses& gt, io::Track track) {
  std::vector<int64_t> out;
  if (track == io::Track::kSingleFrame) {
    for (size_t i = 0; i < gt.keys.size(); i += 5) out.push_back(gt.keys[i]);
    return out;
  }
  std::vector<int64_t> seq1;
  for (int64_t key : gt.keys)
    if (gt.poses.at(key).name.rfind("seq1/", 0) == 0) seq1.push_back(key);
  std::sort(seq1.begin(), seq1.end());
  for (size_t i = 9; i < seq1.size(); i += 10) out.push_back(seq1[i]);
  return out;
}

std::vector<SceneRecord> EvaluateScenes(const EvalInput& in) {
  FREELOC_CHECK(in.submission != nullptr, "EvaluateScenes: no submission");
  std::vector<SceneRecord> out;
  for (const auto& scene : in.scenes) {
    const std::string dir = in.split_dir + "/" + scene;
    SceneRecord rec;
    rec.name = scene;
    const SceneIntrinsics K = LoadIntrinsics(dir + "/intrinsics.txt");
    const std::string gt_text = ReadFile(dir + "/poses.txt", "poses.txt");
    FREELOC_CHECK(io::py::IsValidUtf8(gt_text), dir << "/poses.txt: not UTF-8 text");
    const io::OfficialPoses gt = io::ParseOfficialPoses(gt_text, false);
    for (const auto& d : gt.dropped) FREELOC_LOG(WARNING) << dir << "/poses.txt " << d << " (ignored, as officially)";
    const std::string member = "pose_" + scene + ".txt";
    auto it = in.submission->files.find(member);
    if (it == in.submission->files.end()) {
      // Quirk: a missing scene counts every GT key (before the 1-in-5 subsampling) as a failure.
      const std::vector<int64_t> keys = in.track == io::Track::kSingleFrame ? gt.keys : EvaluatedKeys(gt, in.track);
      rec.failures = static_cast<int64_t>(keys.size());
      for (int64_t key : keys) rec.frames.push_back({scene, key, "scene-missing", {}, 0});
      out.push_back(std::move(rec));
      continue;
    }
    rec.file_present = true;
    FREELOC_CHECK(io::py::IsValidUtf8(it->second),
                  in.submission_path << ": " << member << " is not UTF-8 text; write pose files in UTF-8");
    const io::OfficialPoses est = io::ParseOfficialPoses(it->second, true);
    rec.dropped = est.dropped;
    rec.dropped_count = est.dropped_count;
    for (const int64_t key : EvaluatedKeys(gt, in.track)) {
      FrameRecord f{scene, key, "missing", {}, 0};
      auto e = est.poses.find(key);
      if (e == est.poses.end()) {
        ++rec.failures;
        rec.frames.push_back(f);
        continue;
      }
      FREELOC_CHECK(e->second.confidence >= 0, in.submission_path << ": " << member << ": frame " << e->second.name
                                                                  << " has confidence " << e->second.confidence
                                                                  << "; confidences must be >= 0");
      auto k = K.k.find(key);
      FREELOC_CHECK(k != K.k.end(), dir << "/intrinsics.txt: no intrinsics for frame key " << key);
      f.err = ComputeFrameErrors(gt.poses.at(key), e->second, k->second, K.width, K.height);
      f.confidence = e->second.confidence;
      f.status = "submitted";
      rec.frames.push_back(f);
    }
    out.push_back(std::move(rec));
  }
  return out;
}

}  // namespace freeloc::eval

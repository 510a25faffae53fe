#include "freeloc/geometry/relative_pose.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "freeloc/core/error.h"

namespace freeloc::geometry {
namespace {

struct TwoView {
  Camera ref{600, 600, 320, 240, 640, 480}, query{580, 585, 330, 235, 640, 480};
  Rigid3d truth;
  std::vector<Eigen::Vector2d> p1, p2;
  std::vector<char> is_inlier;
};

// Points 1–10 m in front of both cameras, `noise` px Gaussian noise, a fraction of uniform outliers.
TwoView MakeTwoView(uint32_t seed, int n, double outliers, double noise = 0.5) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> g(0, noise);
  TwoView tv;
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  tv.truth = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.25 * u(rng), axis)),
                     Eigen::Vector3d(u(rng), 0.3 * u(rng), 0.3 * u(rng)).normalized());
  while (static_cast<int>(tv.p1.size()) < n) {
    const bool outlier = std::uniform_real_distribution<double>(0, 1)(rng) < outliers;
    Eigen::Vector2d a(320 + 320 * u(rng), 240 + 240 * u(rng));
    Eigen::Vector2d b;
    if (outlier) {
      b = {320 + 320 * u(rng), 240 + 240 * u(rng)};
    } else {
      const double depth = 1 + 9 * (0.5 + 0.5 * u(rng));
      const Eigen::Vector3d X = tv.ref.Unproject(a.x(), a.y()) * depth;
      const Eigen::Vector3d Y = tv.truth * X;
      if (Y.z() < 0.1) continue;
      b = tv.query.Project(Y);
      if (b.x() < 0 || b.y() < 0 || b.x() > 640 || b.y() > 480) continue;
      a += Eigen::Vector2d(g(rng), g(rng));
      b += Eigen::Vector2d(g(rng), g(rng));
    }
    tv.p1.push_back(a);
    tv.p2.push_back(b);
    tv.is_inlier.push_back(!outlier);
  }
  return tv;
}

double TranslationAngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}

TEST(RelativePose, NoiseFreeIsExact) {
  const TwoView tv = MakeTwoView(1, 200, 0.0, 0.0);
  const RelativePoseResult r = EstimateRelativePose(tv.p1, tv.p2, tv.ref, tv.query);
  ASSERT_TRUE(r.status.success()) << ToString(r.status.outcome);
  EXPECT_LT(RotationAngleDeg(r.query_from_ref.rotation, tv.truth.rotation), 1e-6);
  EXPECT_LT(TranslationAngleDeg(r.query_from_ref.translation, tv.truth.translation), 1e-6);
  EXPECT_EQ(r.status.num_inliers, 200);
  EXPECT_NEAR(r.query_from_ref.translation.norm(), 1.0, 1e-12);
}

// Seeded noise + outliers: error bounds per cell (0.5 px noise).
TEST(RelativePose, RobustUnderNoiseAndOutliers) {
  for (double outliers : {0.25, 0.5, 0.75}) {
    int failures = 0;
    std::vector<double> rot, tra;
    for (uint32_t seed = 0; seed < 10; ++seed) {
      const TwoView tv = MakeTwoView(100 + seed, 1000, outliers);
      RelativePoseOptions o;
      o.ransac.seed = seed;
      o.ransac.max_seconds = 0;  // accuracy, not the time budget: the same result on a slow (e.g. sanitizer) build
      const RelativePoseResult r = EstimateRelativePose(tv.p1, tv.p2, tv.ref, tv.query, o);
      ASSERT_TRUE(r.status.success());
      const double re = RotationAngleDeg(r.query_from_ref.rotation, tv.truth.rotation);
      failures += re > 5;
      rot.push_back(re);
      tra.push_back(TranslationAngleDeg(r.query_from_ref.translation, tv.truth.translation));
      // Inlier classification: nearly all true inliers found, few outliers accepted.
      int tp = 0, fp = 0, pos = 0;
      for (size_t i = 0; i < tv.p1.size(); ++i) {
        pos += tv.is_inlier[i];
        tp += tv.is_inlier[i] && r.inliers[i];
        fp += !tv.is_inlier[i] && r.inliers[i];
      }
      EXPECT_GT(tp, 0.9 * pos);
      EXPECT_LT(fp, 0.05 * tv.p1.size());
    }
    std::sort(rot.begin(), rot.end());
    std::sort(tra.begin(), tra.end());
    EXPECT_EQ(failures, 0) << outliers;
    EXPECT_LT(rot[5], 0.1) << outliers;  // median rotation error, degrees
    EXPECT_LT(tra[5], 0.5) << outliers;  // median translation-direction error, degrees
  }
}

TEST(RelativePose, DeterministicForFixedSeed) {
  const TwoView tv = MakeTwoView(7, 500, 0.5);
  const auto a = EstimateRelativePose(tv.p1, tv.p2, tv.ref, tv.query);
  const auto b = EstimateRelativePose(tv.p1, tv.p2, tv.ref, tv.query);
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_EQ(a.query_from_ref.translation, b.query_from_ref.translation);
}

TEST(RelativePose, DegenerateInputsAreStatusesNotExceptions) {
  Camera c{500, 500, 320, 240, 640, 480};
  std::vector<Eigen::Vector2d> four = {{1, 2}, {3, 4}, {5, 6}, {7, 8}};
  auto r = EstimateRelativePose(four, four, c, c);
  EXPECT_FALSE(r.status.success());
  EXPECT_EQ(r.status.outcome, EstimatorOutcome::kTooFewMatches);
  std::vector<Eigen::Vector2d> same(50, Eigen::Vector2d(100, 100));
  r = EstimateRelativePose(same, same, c, c);
  EXPECT_FALSE(r.status.success());
  std::vector<Eigen::Vector2d> line1, line2;
  for (int i = 0; i < 50; ++i) {
    line1.emplace_back(10 + 5 * i, 20 + 2 * i);
    line2.emplace_back(12 + 5 * i, 21 + 2 * i);
  }
  r = EstimateRelativePose(line1, line2, c, c);  // collinear: no reliable pose
  EXPECT_TRUE(r.query_from_ref.translation.allFinite());
  std::vector<Eigen::Vector2d> bad = line1;
  bad[3].x() = std::nan("");
  try {
    EstimateRelativePose(bad, line2, c, c);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("correspondence 3 has a non-finite coordinate"), std::string::npos);
  }
  EXPECT_THROW(EstimateRelativePose(line1, four, c, c), Error);
}

}  // namespace
}  // namespace freeloc::geometry

namespace freeloc::geometry {
namespace {

// Never a confident wrong answer.
TEST(RelativePoseSafety, FiveMatchesAreTooFewNotOk) {
  const TwoView tv = MakeTwoView(21, 5, 0.0, 0.0);
  const RelativePoseResult r = EstimateRelativePose(tv.p1, tv.p2, tv.ref, tv.query);
  EXPECT_FALSE(r.status.success());
  EXPECT_EQ(r.status.outcome, EstimatorOutcome::kTooFewMatches);
  // Twelve exact matches of real geometry still give the pose.
  const TwoView twelve = MakeTwoView(22, 12, 0.0, 0.0);
  const RelativePoseResult r12 = EstimateRelativePose(twelve.p1, twelve.p2, twelve.ref, twelve.query);
  ASSERT_TRUE(r12.status.success()) << ToString(r12.status.outcome);
  EXPECT_LT(RotationAngleDeg(r12.query_from_ref.rotation, twelve.truth.rotation), 1e-4);
}

TEST(RelativePoseSafety, CollinearPointsAreDegenerate) {
  // Points on one 3D line project onto a line in both images: no essential matrix is determined.
  TwoView tv = MakeTwoView(23, 1, 0.0, 0.0);
  tv.p1.clear();
  tv.p2.clear();
  for (int k = 0; k < 60; ++k) {
    const Eigen::Vector3d X(-1 + 0.03 * k, 0.2 + 0.01 * k, 4 + 0.05 * k);
    tv.p1.push_back(tv.ref.Project(X));
    tv.p2.push_back(tv.query.Project(tv.truth * X));
  }
  const RelativePoseResult r = EstimateRelativePose(tv.p1, tv.p2, tv.ref, tv.query);
  EXPECT_FALSE(r.status.success());
  EXPECT_TRUE(r.status.outcome == EstimatorOutcome::kDegenerate || r.status.outcome == EstimatorOutcome::kNoConsensus)
      << ToString(r.status.outcome);
}

TEST(RelativePoseSafety, RandomMatchesGiveNoConsensusWithinTheBudget) {
  for (uint32_t seed : {31u, 32u}) {
    const TwoView tv = MakeTwoView(seed, 1500, 1.0);  // all outliers
    RelativePoseOptions o;
    o.threshold_px = 3.0;
    const RelativePoseResult r = EstimateRelativePose(tv.p1, tv.p2, tv.ref, tv.query, o);
    EXPECT_FALSE(r.status.success()) << "seed " << seed << ": " << r.status.num_inliers << " inliers, chance "
                                     << r.status.chance_inliers;
    EXPECT_EQ(r.status.outcome, EstimatorOutcome::kNoConsensus);
  }
  // A time budget stops a hopeless search (100 000 random matches once took 23 s to give "ok"); here without the
  // dense-set rule, which would stop it first (RandomDenseSetsGiveUpAfterTheSamplesThatWouldFindAFifth).
  const TwoView big = MakeTwoView(34, 100000, 1.0);
  RelativePoseOptions o;
  o.threshold_px = 3.0;
  o.ransac.max_seconds = 0.5;
  o.ransac.sprt_min_data = 0;
  const RelativePoseResult r = EstimateRelativePose(big.p1, big.p2, big.ref, big.query, o);
  EXPECT_FALSE(r.status.success());
  EXPECT_EQ(r.status.stop, RansacStop::kTimeBudget);
  // Real geometry with 70 % outliers still passes the chance test.
  const TwoView real = MakeTwoView(35, 2000, 0.7, 0.5);
  RelativePoseOptions fresh;
  fresh.threshold_px = 3.0;
  fresh.ransac.max_seconds = 0;
  const RelativePoseResult rr = EstimateRelativePose(real.p1, real.p2, real.ref, real.query, fresh);
  ASSERT_TRUE(rr.status.success()) << ToString(rr.status.outcome);
  EXPECT_LT(RotationAngleDeg(rr.query_from_ref.rotation, real.truth.rotation), 0.5);
}

// Dense sets (ransac.h): random matches stop after the samples that would have found a model holding a fifth of
// them — counted in samples, not seconds — while a solvable dense set gives the answer the plain search gives.
TEST(RelativePoseSafety, RandomDenseSetsGiveUpAfterTheSamplesThatWouldFindAFifth) {
  for (uint32_t seed : {41u, 42u}) {
    const TwoView tv = MakeTwoView(seed, 40000, 1.0);
    RelativePoseOptions o;
    o.ransac.seed = seed;
    const RelativePoseResult r = EstimateRelativePose(tv.p1, tv.p2, tv.ref, tv.query, o);
    EXPECT_EQ(r.status.outcome, EstimatorOutcome::kNoConsensus) << "seed " << seed;
    EXPECT_TRUE(r.status.stop == RansacStop::kNoModel || r.status.stop == RansacStop::kGaveUp)
        << ToString(r.status.stop);
    // The give-up bound for a fifth of 40 000 at 99 % is about 14 400 samples (a little more for the test's losses);
    // the search without the rule ran to its 10 s budget.
    const double bound = RequiredIterations(8000, 40000, 5, o.ransac.give_up_prob, 0.97);
    EXPECT_LE(r.status.iterations, static_cast<int>(bound) + 1);
    EXPECT_GE(r.status.iterations, static_cast<int>(RequiredIterations(8000, 40000, 5, o.ransac.give_up_prob)));
  }
}

// A solvable set under the dense rule (sequential test + give-up from `sprt_min_data` matches) against the plain
// search: both refine on the same inlier set, so the same pose to well below the noise (within `same_deg`, and
// `truth_deg` of the truth), nearly the same support (`inlier_share`), and the test drops most hypotheses early (no
// more samples than the plain search, give or take).
void ExpectThePlainSearchsAnswer(const TwoView& tv, int sprt_min_data, double truth_deg, double same_deg,
                                 double inlier_share) {
  RelativePoseOptions rule, plain;
  rule.ransac.sprt_min_data = sprt_min_data;
  plain.ransac.sprt_min_data = 0;
  const RelativePoseResult a = EstimateRelativePose(tv.p1, tv.p2, tv.ref, tv.query, rule);
  const RelativePoseResult b = EstimateRelativePose(tv.p1, tv.p2, tv.ref, tv.query, plain);
  ASSERT_TRUE(a.status.success()) << ToString(a.status.outcome);
  ASSERT_TRUE(b.status.success()) << ToString(b.status.outcome);
  EXPECT_EQ(a.status.stop, RansacStop::kConfidence);
  EXPECT_LT(RotationAngleDeg(a.query_from_ref.rotation, tv.truth.rotation), truth_deg);
  EXPECT_LT(RotationAngleDeg(a.query_from_ref.rotation, b.query_from_ref.rotation), same_deg);
  EXPECT_NEAR(a.status.num_inliers, b.status.num_inliers, inlier_share * b.status.num_inliers);
  EXPECT_LE(a.status.iterations, b.status.iterations * 1.1 + 60);
}

// The dense rule on a sparse set (sprt_min_data = 1: the hybrid route's essential guard, pipeline/stages.cc): 500
// random matches stop at the same give-up bound, and a solvable 500-match set gives the plain search's answer.
TEST(RelativePoseSafety, TheDenseRuleOnASparseSetGivesUpAtTheSameBound) {
  for (uint32_t seed : {43u, 44u}) {
    const TwoView tv = MakeTwoView(seed, 500, 1.0);
    RelativePoseOptions o;
    o.ransac.seed = seed;
    o.ransac.sprt_min_data = 1;
    const RelativePoseResult r = EstimateRelativePose(tv.p1, tv.p2, tv.ref, tv.query, o);
    EXPECT_EQ(r.status.outcome, EstimatorOutcome::kNoConsensus) << "seed " << seed;
    EXPECT_TRUE(r.status.stop == RansacStop::kNoModel || r.status.stop == RansacStop::kGaveUp)
        << ToString(r.status.stop);
    EXPECT_LE(r.status.iterations, static_cast<int>(RequiredIterations(100, 500, 5, o.ransac.give_up_prob, 0.9)) + 1);
  }
  ExpectThePlainSearchsAnswer(MakeTwoView(45, 500, 0.5), /*sprt_min_data=*/1, 0.3, 0.05, 0.012);
}

TEST(RelativePose, DenseSetsGiveThePlainSearchsAnswer) {
  for (const double outliers : {0.3, 0.7})
    ExpectThePlainSearchsAnswer(MakeTwoView(51, 20000, outliers), /*sprt_min_data=*/2000, 0.1, 0.01, 0.005);
}

// A few hundred random matches (what random-weight descriptor matchers give): RANSAC's search selects a model with
// a dozen chance inliers, which beats the fixed-model chance test; the same search on shuffled pairs finds as many,
// so the answer is no-consensus. Weak but real geometry (20 % inliers of 200) still passes.
TEST(RelativePoseSafety, SearchOnShuffledPairsRejectsSelectedChanceModels) {
  int refused = 0;
  for (uint32_t seed = 40; seed < 44; ++seed) {
    const TwoView tv = MakeTwoView(seed, 200, 1.0);
    RelativePoseOptions o;
    o.ransac.max_seconds = 1.0;  // the hopeless search runs to its budget; keep the test short
    const RelativePoseResult r = EstimateRelativePose(tv.p1, tv.p2, tv.ref, tv.query, o);
    EXPECT_FALSE(r.status.success()) << "seed " << seed << ": " << r.status.num_inliers << " inliers, shuffled best "
                                     << r.status.shuffled_best;
    refused += r.status.outcome == EstimatorOutcome::kNoConsensus;
  }
  EXPECT_EQ(refused, 4);
  for (uint32_t seed = 50; seed < 53; ++seed) {
    const TwoView weak = MakeTwoView(seed, 200, 0.8, 0.3);
    const RelativePoseResult r = EstimateRelativePose(weak.p1, weak.p2, weak.ref, weak.query);
    ASSERT_TRUE(r.status.success()) << "seed " << seed << ": " << ToString(r.status.outcome) << ", "
                                    << r.status.num_inliers << " inliers, shuffled best " << r.status.shuffled_best;
    EXPECT_GE(r.status.shuffled_best, 0);  // the weak-support check ran
    EXPECT_LT(RotationAngleDeg(r.query_from_ref.rotation, weak.truth.rotation), 1.0);
  }
}

}  // namespace
}  // namespace freeloc::geometry

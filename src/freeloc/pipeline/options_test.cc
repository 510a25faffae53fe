// Typed options: every enum and spec round-trips through its one text form; errors name the field and the choices;
// the field table sets and reads every field; presets resolve; the JSON records round-trip.
#include "freeloc/pipeline/options.h"

#include <gtest/gtest.h>

#include "freeloc/core/error.h"
#include "freeloc/pipeline/record.h"
#include "testing/testing.h"

namespace freeloc::pipeline {
namespace {

using testing::ErrorOf;

TEST(Options, SpecsRoundTripThroughTheirTextForm) {
  for (const char* t : {"sift", "dust3r", "dust3r+instances", "precomputed:SIFT", "precomputed:LoFTR"})
    EXPECT_EQ(MatcherSpec::FromString(t).ToString(), t);
  for (const char* t : {"provided:sensor", "provided:gt", "metric3d", "none"})
    EXPECT_EQ(DepthSpec::FromString(t).ToString(), t);
  EXPECT_EQ(MatcherSpec::FromString("precomputed:SG").correspondences, "SG");
  EXPECT_EQ(DepthSpec::FromString("provided:dpt").suffix, "dpt");
  for (const auto& e : EnumTable<QueryStatus>::kEntries) EXPECT_EQ(ParseEnum<QueryStatus>(e.name), e.value);
}

TEST(Options, BadTextNamesTheFieldAndTheChoicesNotAFlag) {
  EXPECT_EQ(
      ErrorOf([] { MatcherSpec::FromString("orb"); }),
      "matcher: 'orb' is not one of sift, dust3r, dust3r+instances, mast3r, mast3r+instances, precomputed:<name>");
  EXPECT_EQ(ErrorOf([] { MatcherSpec::FromString("sift:x"); }).rfind("matcher: 'sift:x'", 0), 0u);
  EXPECT_NE(ErrorOf([] { MatcherSpec::FromString("precomputed:"); }).find("names no correspondences"),
            std::string::npos);
  EXPECT_EQ(ErrorOf([] { DepthSpec::FromString("provided"); }),
            "depth: 'provided' is not one of provided:<suffix>, metric3d, mast3r, none");
  PipelineOptions o;
  EXPECT_EQ(ErrorOf([&] { SetOption(&o, "solver", "ransac"); }),
            "solver: 'ransac' is not one of essential, pnp, procrustes, hybrid");
  EXPECT_EQ(ErrorOf([&] { SetOption(&o, "threshold_px", "1.5px"); }), "threshold_px: '1.5px' is not a finite number");
  EXPECT_EQ(ErrorOf([&] { SetOption(&o, "precision", "fp8"); }), "precision: 'fp8' is not one of fp32, bf16");
  EXPECT_EQ(ErrorOf([&] { SetOption(&o, "dust3r_size", "2.5"); }), "dust3r_size: '2.5' is not an integer");
  EXPECT_EQ(ErrorOf([&] { SetOption(&o, "colour", "red"); }).rfind("colour: not an option; the options are preset,", 0),
            0u);
  o = ResolvePreset("sift-pnp");
  o.depth.kind = DepthKind::kNone;
  const std::string v = ErrorOf([&] { o.Validate(); });
  EXPECT_EQ(v.rfind("solver: pnp needs depth", 0), 0u) << v;
  EXPECT_EQ(v.find("--"), std::string::npos) << v;  // no CLI flag in a library error
}

TEST(Options, EveryFieldSetsAndReadsBack) {
  PipelineOptions o;
  for (const OptionField& f : OptionFields()) {
    const std::string before = GetOption(o, f.name);
    SetOption(&o, f.name, before);
    EXPECT_EQ(GetOption(o, f.name), before) << f.name;
  }
  SetOption(&o, "matcher", "dust3r+instances");
  SetOption(&o, "instance_source", "given");
  SetOption(&o, "proposals.max_instances", "7");
  SetOption(&o, "segmenter.min_score", "0.125");
  SetOption(&o, "threads", "3");
  EXPECT_TRUE(o.UsesInstances());
  EXPECT_FALSE(o.UsesSegGpt());
  EXPECT_EQ(o.instances.proposals.max_instances, 7);
  EXPECT_EQ(o.instances.segmenter.min_score, 0.125);
  EXPECT_EQ(o.runtime.threads, 3);
}

TEST(Options, PresetsResolveToTypedOptions) {
  EXPECT_EQ(ResolvePreset("sift-pnp").solver, SolverKind::kPnp);
  EXPECT_EQ(ResolvePreset("precomputed:LoFTR-procrustes").matcher.ToString(), "precomputed:LoFTR");
  EXPECT_EQ(ResolvePreset("precomputed:SG-essential").solve.threshold_px, 2.0);
  EXPECT_EQ(ResolvePreset("precomputed:SIFT-essential").solve.threshold_px, 3.0);
  EXPECT_EQ(ResolvePreset("sift-essential").depth.ToString(), "provided:sensor");
  EXPECT_EQ(ResolvePreset("seed").matcher.kind, MatcherKind::kDust3rInstances);
  EXPECT_EQ(ResolvePreset("seed").depth.kind, DepthKind::kMetric3d);
  EXPECT_THROW(ResolvePreset("magic"), Error);
  EXPECT_THROW(ResolvePreset("precomputed:SIFT"), Error);
  EXPECT_THROW(ResolvePreset("precomputed:SIFT-ransac"), Error);
  for (const std::string& p : PresetNames())
    if (p.find('<') == std::string::npos) {
      EXPECT_EQ(ResolvePreset(p).preset, p);
    }
}

TEST(Records, OptionsAndQueryResultsRoundTrip) {
  PipelineOptions o = ResolvePreset("precomputed:LoFTR-pnp");
  o.solve.threshold_px = 0.1 + 0.2;  // not exactly representable in decimal: must come back bit for bit
  o.runtime.threads = 2;
  const PipelineOptions back = OptionsFromJson(OptionsJson(o));
  for (const OptionField& f : OptionFields()) EXPECT_EQ(GetOption(back, f.name), GetOption(o, f.name)) << f.name;
  EXPECT_EQ(back.solve.threshold_px, o.solve.threshold_px);
  QueryResult r;
  r.frame = "seq1/frame_00003.jpg";
  r.status = QueryStatus::kError;
  r.message = "s1/seq1/frame_00003.jpg: not an image";
  r.query_from_ref = Rigid3d(Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2).normalized(), Eigen::Vector3d(0.1, -2.0 / 3, 7));
  r.confidence = 1.0 / 3;
  r.matches = 17;
  std::string scene;
  const QueryResult q = QueryResultFromJson(QueryRecordJson("s1", r, &o), &scene);
  EXPECT_EQ(scene, "s1");
  EXPECT_EQ(q.frame, r.frame);
  EXPECT_EQ(q.status, r.status);
  EXPECT_EQ(q.message, r.message);
  EXPECT_EQ(q.confidence, r.confidence);
  EXPECT_EQ(q.query_from_ref.translation, r.query_from_ref.translation);
  EXPECT_EQ(q.query_from_ref.QuaternionWxyz(), r.query_from_ref.QuaternionWxyz());
  // The 0.1 log form "error: <message>" still reads.
  const QueryResult old = QueryResultFromJson(
      R"({"frame":"f","status":"error: a.png: bad","confidence":0,"matches":0,"inliers":0,"qvec":[1,0,0,0],)"
      R"("tvec":[0,0,0]})");
  EXPECT_EQ(old.status, QueryStatus::kError);
  EXPECT_EQ(old.message, "a.png: bad");
  EXPECT_THROW(QueryResultFromJson(R"({"status":"fine"})"), Error);
}

TEST(Records, RunHeaderCarriesVersionAndOptionsAndComparesResultOptions) {
  RunHeader h;
  h.options = ResolvePreset("sift-essential");
  h.data = "/d";
  h.split = "val";
  h.shard = "1/2";
  h.scenes = {"s1", "s3"};
  const std::string j = RunHeaderJson(h, R"({"summary":{"queries":3}})");
  EXPECT_NE(j.find("\"freeloc_version\":\""), std::string::npos) << j;
  EXPECT_NE(j.find("\"matcher\":\"sift\""), std::string::npos) << j;
  EXPECT_NE(j.find("\"shard\":\"1/2\""), std::string::npos) << j;
  EXPECT_NE(j.find("\"summary\":{\"queries\":3}"), std::string::npos) << j;
  std::string why;
  PipelineOptions same = h.options;
  same.runtime.threads = 7;  // threads do not change results
  EXPECT_TRUE(SameResultOptions(j, same, &why)) << why;
  PipelineOptions other = h.options;
  other.solver = SolverKind::kPnp;
  EXPECT_FALSE(SameResultOptions(j, other, &why));
  EXPECT_EQ(why, "solver \"essential\" vs \"pnp\"");
  EXPECT_FALSE(SameResultOptions("{\"freeloc_progress\":1}", same, &why));
}

}  // namespace
}  // namespace freeloc::pipeline

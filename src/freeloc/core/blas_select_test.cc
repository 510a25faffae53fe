// The OpenBLAS core-type decision on simulated CPUs (tests/data/blas/coretype_cases.json, shared with the Python
// package's copy of the table), and /proc/cpuinfo parsing.
#include "freeloc/core/blas_select.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "testing/testing.h"

namespace freeloc {
namespace {

TEST(BlasSelect, DecisionTableOnSimulatedCpus) {
  const nlohmann::json j =
      nlohmann::json::parse(testing::ReadText(testing::SourceDir() + "/tests/data/blas/coretype_cases.json"));
  int n = 0;
  for (const auto& c : j.at("cases")) {
    SCOPED_TRACE(c.at("name").get<std::string>());
    CpuDescription cpu;
    cpu.vendor = c.at("vendor");
    std::istringstream fl(c.at("flags").get<std::string>());
    for (std::string f; fl >> f;) cpu.flags.insert(f);
    EXPECT_EQ(ChooseOpenBlasCoretype(cpu, c.at("reported")), c.at("expect").get<std::string>());
    ++n;
  }
  EXPECT_GE(n, 10);
}

TEST(BlasSelect, ParsesTheFirstProcessorOfCpuinfo) {
  const CpuDescription cpu = ParseCpuInfo(
      "processor\t: 0\nvendor_id\t: GenuineIntel\nmodel name\t: Intel(R) Xeon(R) Platinum 8581C CPU @ 2.10GHz\n"
      "flags\t\t: fpu avx2 fma avx512f avx512bw\n\nprocessor\t: 1\nvendor_id\t: Other\nflags\t\t: none\n");
  EXPECT_EQ(cpu.vendor, "GenuineIntel");
  EXPECT_EQ(cpu.model_name, "Intel(R) Xeon(R) Platinum 8581C CPU @ 2.10GHz");
  EXPECT_TRUE(cpu.Has("avx512bw"));
  EXPECT_FALSE(cpu.Has("none"));
  EXPECT_TRUE(ParseCpuInfo("").flags.empty());
  // This machine: whatever it is, the decision never names a kernel its flags cannot run.
  const CpuDescription me = ThisCpu();
  const std::string pick = ChooseOpenBlasCoretype(me, "Prescott");
  if (pick == "SkylakeX" || pick == "Cooperlake") {
    EXPECT_TRUE(me.Has("avx512f"));
  }
  if (pick == "Haswell" || pick == "Zen") {
    EXPECT_TRUE(me.Has("avx2"));
  }
}

}  // namespace
}  // namespace freeloc

// Runs the `freeloc` binary and checks its output and exit codes (0 ok, 1 input error, 2 usage error).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <string>

#include "testing/testing.h"

namespace {

struct Result {
  int code = -1;
  std::string out;  // stdout and stderr together
};

Result RunFreeloc(const std::string& args) {
  Result r;
  const std::string cmd = std::string(FREELOC_BINARY) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

bool Contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

TEST(Cli, HelpAndVersion) {
  Result h = RunFreeloc("--help");
  EXPECT_EQ(h.code, 0);
  EXPECT_TRUE(Contains(h.out, "inspect")) << h.out;
  EXPECT_TRUE(Contains(h.out, "--threads")) << h.out;
  EXPECT_TRUE(Contains(h.out, "--device")) << h.out;
  Result v = RunFreeloc("--version");
  EXPECT_EQ(v.code, 0);
  EXPECT_TRUE(Contains(v.out, "freeloc 0.")) << v.out;
}

TEST(Cli, UsageErrorsExitTwo) {
  EXPECT_EQ(RunFreeloc("").code, 2);
  EXPECT_EQ(RunFreeloc("no-such-command").code, 2);
  EXPECT_EQ(RunFreeloc("--device tpu inspect x").code, 2);
  EXPECT_EQ(RunFreeloc("--threads 0 inspect x").code, 2);
  EXPECT_EQ(RunFreeloc("--quiet --verbose demo").code, 2);
  Result r = RunFreeloc("inspect");
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(Contains(r.out, "FILE")) << r.out;
}

TEST(Cli, InputErrorsExitOneWithOneLine) {
  freeloc::testing::TempDir tmp;
  Result r = RunFreeloc("inspect " + tmp.File("missing.pth"));
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "missing.pth")) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  freeloc::testing::WriteText(tmp.File("junk.safetensors"), "this is not a checkpoint at all");
  r = RunFreeloc("inspect " + tmp.File("junk.safetensors"));
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "junk.safetensors")) << r.out;
}

TEST(Cli, InspectDust3rPth) {
  FREELOC_REQUIRE_SHARED("fixtures/pth/dust3r_tiny.pth");
  Result r = RunFreeloc("inspect " + freeloc::testing::SharedPath("fixtures/pth/dust3r_tiny.pth"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "tensors:  745")) << r.out;
  EXPECT_TRUE(Contains(r.out, "model constructor (args.model): AsymmetricCroCo3DStereo(pos_embed='RoPE100'")) << r.out;
  EXPECT_TRUE(Contains(r.out, "model.patch_embed.proj.weight")) << r.out;
  EXPECT_TRUE(Contains(r.out, "float32  [64, 3, 16, 16]")) << r.out;
}

TEST(Cli, InspectSafetensorsWithFilter) {
  FREELOC_REQUIRE_SHARED("fixtures/dust3r/weights.safetensors");
  Result r =
      RunFreeloc("inspect --filter enc_norm " + freeloc::testing::SharedPath("fixtures/dust3r/weights.safetensors"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "format:   safetensors")) << r.out;
  EXPECT_TRUE(Contains(r.out, "enc_norm.weight")) << r.out;
  EXPECT_TRUE(Contains(r.out, "(2 of 745 tensors match 'enc_norm')")) << r.out;
}

TEST(Cli, DemoPlaceholderSaysSo) {
  Result r = RunFreeloc("demo");
  EXPECT_EQ(r.code, 0);
  EXPECT_TRUE(Contains(r.out, "PLACEHOLDER")) << r.out;
}

}  // namespace

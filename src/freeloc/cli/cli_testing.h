// What the CLI tests share: the `freeloc` binary run as a user runs it, its output (stdout and stderr) and exit code.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <initializer_list>
#include <string>

namespace {

struct Result {
  int code = -1;
  std::string out;  // stdout and stderr together
};

// `env` sets the environment; by default $FREELOC_MODELS is unset, so model discovery sees only what a test gives.
inline Result RunFreeloc(const std::string& args, const std::string& env = "-u FREELOC_MODELS") {
  Result r;
  const std::string cmd = "env " + env + " " + std::string(FREELOC_BINARY) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

inline bool Contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }
// Every part appears in `out` (each missing part is its own failure, with the whole output).
inline void ExpectMentions(const std::string& out, std::initializer_list<const char*> parts) {
  for (const char* part : parts) EXPECT_TRUE(Contains(out, part)) << "missing: " << part << "\n" << out;
}

}  // namespace

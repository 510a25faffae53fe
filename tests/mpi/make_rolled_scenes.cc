// Writes synthetic map-free scenes whose queries are rolled 80–126° (a phone held sideways) for the MPI test:
// `make_rolled_scenes ROOT N` → ROOT/val/s90000 … (precomputed SIFT correspondences, depth suffix gt). Large
// rotations are where a pose read back from its record and written again once moved its last bit.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "testing/mapfree_writer.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: make_rolled_scenes ROOT N\n");
    return 2;
  }
  freeloc::testing::SyntheticMapfreeOptions o;
  o.queries = 25;
  o.width = o.height = 240;
  o.roll_rad = 1.4;
  for (int s = 0; s < std::atoi(argv[2]); ++s) {
    char name[32];
    std::snprintf(name, sizeof(name), "s9%04d", s);
    freeloc::testing::WriteSyntheticMapfreeScene(std::string(argv[1]) + "/val/" + name, 9000 + s, o);
  }
  return 0;
}

#include "freeloc/core/version.h"

#ifndef FREELOC_VERSION
#error "FREELOC_VERSION is set by src/freeloc/core/CMakeLists.txt"
#endif

namespace freeloc {

const char* Version() { return FREELOC_VERSION; }

}  // namespace freeloc

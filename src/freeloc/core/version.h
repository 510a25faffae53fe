// freeloc's version (the CMake project version), recorded in every output that says what made it.
#pragma once

namespace freeloc {

const char* Version();

}  // namespace freeloc

// libFuzzer target: the service's multipart/form-data parser (service/multipart.h), which freeloc owns since the
// transport moved to Boost.Beast. The first byte picks the boundary's length; the rest is the body. Every part given
// back must lie inside the body and respect the bounds.
#include "freeloc/service/multipart.h"

#include <cstdlib>

#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  if (size == 0) return 0;
  const size_t blen = std::min<size_t>(data[0] % 80, size - 1);
  const std::string boundary(reinterpret_cast<const char*>(data + 1), blen);
  const std::string body(reinterpret_cast<const char*>(data + 1 + blen), size - 1 - blen);
  fuzz::Expect([&] {
    const auto parts = service::http::ParseMultipart(body, "multipart/form-data; boundary=" + boundary);
    if (parts.size() > 16) std::abort();
    for (const auto& [name, p] : parts)
      if (name.empty() || name.size() > 64 || name != p.name || p.content.size() > body.size()) std::abort();
  });
  return 0;
}

// libFuzzer target, structure-aware: the fuzzer's bytes choose the *metadata* of well-formed safetensors and .npy
// headers — dtypes, shapes (negative, huge, overflowing products), data offsets, the declared header length and the
// data actually present — and the readers parse them with every tensor touched. Byte mutation rarely keeps a JSON
// or Python-dict header valid while making its numbers lie; this target does nothing else.
#include <cstdint>
#include <string>
#include <vector>

#include "freeloc/io/npz.h"
#include "freeloc/io/safetensors.h"
#include "fuzz_input.h"

namespace {

using freeloc::fuzz::Choices;

// A JSON number that may lie: an int64 edge value, now and then as unsigned 2^64 − 1 or a fraction.
std::string JsonInt(Choices& c) {
  switch (c.Byte() % 16) {
    case 0: return "18446744073709551615";
    case 1: return "1.5";
    case 2: return "1e300";
    default: return std::to_string(c.Int());
  }
}

std::string Safetensors(Choices& c) {
  static const char* kDtypes[] = {"F32", "F16", "BF16", "F64", "I64", "I32", "I16", "I8", "U8", "BOOL", "X9"};
  const int n = 1 + c.Byte() % 3;
  std::string h = "{";
  for (int t = 0; t < n; ++t) {
    h += (t ? "," : "") + std::string("\"t") + std::to_string(t) + "\":{\"dtype\":\"" + kDtypes[c.Byte() % 11] +
         "\",\"shape\":[";
    const int nd = c.Byte() % 4;
    for (int d = 0; d < nd; ++d) h += (d ? "," : "") + JsonInt(c);
    h += "],\"data_offsets\":[" + JsonInt(c) + "," + JsonInt(c) + "]}";
  }
  if (c.Byte() % 4 == 0) h += ",\"__metadata__\":{\"format\":\"pt\"}";
  h += "}";
  const uint64_t data = c.Byte() % 2 ? c.Byte() : static_cast<uint64_t>(c.Byte()) * 16;
  uint64_t declared = h.size();
  switch (c.Byte() % 8) {
    case 0: declared = static_cast<uint64_t>(c.Int()); break;  // a header length that lies
    case 1: declared = h.size() + c.Byte(); break;
    default: break;
  }
  std::string out;
  for (int k = 0; k < 8; ++k) out += static_cast<char>((declared >> (8 * k)) & 0xff);
  return out + h + std::string(data, '\x3c');
}

std::string Npy(Choices& c) {
  static const char* kDescr[] = {"<f4", "<f8", "<f2", "<i8", "<i4", "<i2", "|i1", "|u1", "|b1", ">f4", "<c8", "<U3"};
  std::string d = "{'descr': '" + std::string(kDescr[c.Byte() % 12]) +
                  "', 'fortran_order': " + (c.Byte() % 2 ? "True" : "False") + ", 'shape': (";
  const int nd = c.Byte() % 4;
  for (int k = 0; k < nd; ++k) d += std::to_string(c.Int()) + (nd == 1 || k + 1 < nd ? "," : "");
  d += "), }";
  while ((10 + d.size() + 1) % 64) d += ' ';
  d += '\n';
  uint16_t len = static_cast<uint16_t>(d.size());
  if (c.Byte() % 8 == 0) len = static_cast<uint16_t>(c.Int());  // a header length that lies
  std::string out = std::string("\x93NUMPY\x01\x00", 8);
  out += static_cast<char>(len & 0xff);
  out += static_cast<char>(len >> 8);
  const size_t data = c.Byte() % 2 ? c.Byte() : static_cast<size_t>(c.Byte()) * 16;
  return out + d + std::string(data, '\x11');
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  Choices c(data, size);
  const bool npy = c.Byte() % 2;
  const std::string bytes = npy ? Npy(c) : Safetensors(c);
  const auto* b = reinterpret_cast<const uint8_t*>(bytes.data());
  fuzz::Expect([&] {
    if (npy) {
      const io::NpyArray a = io::ParseNpy(b, bytes.size(), "fuzz.npy");
      double s = 0;
      for (double v : a.data) s += v;
      if (s == 1.25) std::fprintf(stderr, " ");
    } else {
      const io::SafetensorsFile f = io::SafetensorsFile::Parse(b, bytes.size(), nullptr, "fuzz.safetensors");
      uint64_t s = 0;
      for (const auto& name : f.names) s += fuzz::Touch(f.Get(name));
      if (s == 1) std::fprintf(stderr, " ");
    }
  });
  return 0;
}

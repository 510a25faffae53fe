#include "freeloc/io/safetensors.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>

#include "freeloc/core/error.h"
#include "freeloc/core/limits.h"
#include "freeloc/io/file_util.h"

namespace freeloc::io {

namespace {
constexpr uint64_t kMaxHeader = 100ull << 20;  // the official loaders refuse headers over 100 MB as well

struct Range {
  uint64_t begin, end;
  std::string name;
};

// Counts a header's values and nesting without building it; stops (returns false) past the bounds.
struct HeaderBounds {
  int64_t max_values = 0;
  int64_t values = 0;
  int depth = 0;
  bool depth_exceeded = false;
  std::string error;
  bool Value() { return ++values <= max_values; }
  bool null() { return Value(); }
  bool boolean(bool) { return Value(); }
  bool number_integer(int64_t) { return Value(); }
  bool number_unsigned(uint64_t) { return Value(); }
  bool number_float(double, const std::string&) { return Value(); }
  bool string(std::string&) { return Value(); }
  bool binary(std::vector<uint8_t>&) { return Value(); }
  bool key(std::string&) { return Value(); }
  bool Open() {
    depth_exceeded = ++depth > 4;
    return !depth_exceeded && Value();
  }
  bool start_object(size_t) { return Open(); }
  bool start_array(size_t) { return Open(); }
  bool end_object() { return --depth, true; }
  bool end_array() { return --depth, true; }
  bool parse_error(size_t, const std::string&, const nlohmann::detail::exception& e) {
    error = e.what();
    return false;
  }
};

// One tensor entry of the header: dtype, shape and data_offsets checked against each other and the data size.
TensorView ParseEntry(const nlohmann::json& entry, const std::string& where, const std::string& fix, uint64_t data_size,
                      uint64_t* begin, uint64_t* end) {
  FREELOC_CHECK(entry.is_object(), where << "entry is not an object" << fix);
  FREELOC_CHECK(entry.contains("dtype") && entry["dtype"].is_string(), where << "missing dtype" << fix);
  FREELOC_CHECK(entry.contains("shape") && entry["shape"].is_array(), where << "missing shape" << fix);
  FREELOC_CHECK(entry.contains("data_offsets") && entry["data_offsets"].is_array() && entry["data_offsets"].size() == 2,
                where << "missing data_offsets [begin, end]" << fix);
  TensorView t;
  const std::string dt = entry["dtype"].get<std::string>();
  FREELOC_CHECK(DTypeFromName(dt, &t.dtype),
                where << "dtype '" << dt << "' is not supported (F64, F32, F16, BF16, I64, I32, I16, I8, U8, BOOL)");
  uint64_t numel = 1;
  for (const auto& s : entry["shape"]) {
    FREELOC_CHECK(s.is_number_unsigned() || (s.is_number_integer() && s.get<int64_t>() >= 0),
                  where << "shape entries must be non-negative integers" << fix);
    const uint64_t d = s.get<uint64_t>();
    FREELOC_CHECK(d == 0 || numel <= std::numeric_limits<uint64_t>::max() / 16 / d,
                  where << "shape is absurdly large" << fix);
    numel *= d;
    t.shape.push_back(static_cast<int64_t>(d));
  }
  const auto& off = entry["data_offsets"];
  FREELOC_CHECK(off[0].is_number_unsigned() && off[1].is_number_unsigned(),
                where << "data_offsets must be non-negative integers" << fix);
  const uint64_t b = off[0].get<uint64_t>(), e = off[1].get<uint64_t>();
  FREELOC_CHECK(b <= e, where << "data_offsets [" << b << ", " << e << ") are reversed" << fix);
  FREELOC_CHECK(e <= data_size, where << "data_offsets [" << b << ", " << e << ") run past the end of the data ("
                                      << data_size << " bytes)" << fix);
  const uint64_t expected = numel * DTypeSize(t.dtype);
  FREELOC_CHECK(e - b == expected, where << "holds " << (e - b) << " bytes but shape " << t.ShapeString() << " of "
                                         << dt << " needs " << expected << fix);
  t.nbytes = static_cast<size_t>(expected);
  *begin = b;
  *end = e;
  return t;
}

// The tensors must tile the data section: no overlaps, no holes, nothing trailing (as the official loader checks).
void CheckTiling(std::vector<Range> ranges, uint64_t data_size, const std::string& bad, const std::string& fix) {
  std::sort(ranges.begin(), ranges.end(),
            [](const Range& a, const Range& b) { return a.begin != b.begin ? a.begin < b.begin : a.end < b.end; });
  uint64_t pos = 0;
  for (const auto& r : ranges) {
    FREELOC_CHECK(r.begin >= pos, bad << "tensor '" << r.name << "' overlaps the previous tensor's bytes" << fix);
    FREELOC_CHECK(r.begin == pos,
                  bad << "gap of " << (r.begin - pos) << " bytes before tensor '" << r.name << "'" << fix);
    pos = r.end;
  }
  FREELOC_CHECK(pos == data_size,
                bad << (data_size - pos) << " bytes after the last tensor are not described by the header" << fix);
}

}  // namespace

SafetensorsFile SafetensorsFile::Parse(const uint8_t* bytes, size_t size, std::shared_ptr<const void> owner,
                                       const std::string& what) {
  const std::string bad = what + ": not a valid safetensors file: ";
  const std::string fix = "; the file is damaged or was not written by a safetensors writer";
  FREELOC_CHECK(size >= 8, bad << "only " << size << " bytes, too short for the 8-byte header length" << fix);
  uint64_t n = 0;
  for (int i = 7; i >= 0; --i) n = (n << 8) | bytes[i];
  FREELOC_CHECK(n <= size - 8,
                bad << "header length " << n << " runs past the end of the file (" << size << " bytes)" << fix);
  FREELOC_CHECK(n <= kMaxHeader, bad << "header length " << n << " exceeds 100 MB" << fix);
  FREELOC_CHECK(n >= 2, bad << "header of " << n << " bytes cannot hold a JSON object" << fix);
  // nlohmann::json (a sorted map: O(n log n), where the insertion-ordered map was quadratic in the tensor count).
  // A SAX pass first bounds nesting and size to what a header can need (nlohmann's parse callbacks are themselves
  // quadratic, so they are not used).
  HeaderBounds bounds;
  bounds.max_values = 16 * Limits().max_tensors + 1024;
  bool well_formed = false;
  try {
    well_formed = nlohmann::json::sax_parse(bytes + 8, bytes + 8 + n, &bounds);
  } catch (const nlohmann::json::exception& e) {
    FREELOC_THROW(bad << "header is not valid JSON (" << e.what() << ")" << fix);
  }
  FREELOC_CHECK(bounds.depth_exceeded == false, bad << "header nests deeper than a safetensors header does" << fix);
  FREELOC_CHECK(bounds.values <= bounds.max_values, what << ": safetensors header holds more than " << bounds.max_values
                                                         << " values; refused (" << LimitHint("max_tensors") << ")");
  FREELOC_CHECK(well_formed, bad << "header is not valid JSON (" << bounds.error << ")" << fix);
  nlohmann::json header;
  try {
    header = nlohmann::json::parse(bytes + 8, bytes + 8 + n);
  } catch (const nlohmann::json::exception& e) {
    FREELOC_THROW(bad << "header is not valid JSON (" << e.what() << ")" << fix);
  }
  FREELOC_CHECK(header.is_object(), bad << "header is not a JSON object" << fix);

  SafetensorsFile f;
  f.path = what;
  const uint8_t* data_start = bytes + 8 + n;
  const uint64_t data_size = size - 8 - n;
  std::vector<Range> ranges;
  for (auto it = header.begin(); it != header.end(); ++it) {
    const std::string& name = it.key();
    const auto& entry = it.value();
    if (name == "__metadata__") {
      FREELOC_CHECK(entry.is_object(), bad << "__metadata__ is not an object" << fix);
      for (auto m = entry.begin(); m != entry.end(); ++m) {
        FREELOC_CHECK(m.value().is_string(), bad << "__metadata__ value of '" << m.key() << "' is not a string" << fix);
        f.metadata[m.key()] = m.value().get<std::string>();
      }
      continue;
    }
    uint64_t b = 0, e = 0;
    TensorView t = ParseEntry(entry, bad + "tensor '" + name + "': ", fix, data_size, &b, &e);
    t.data = data_start + b;
    t.owner = owner;
    ranges.push_back({b, e, name});
    f.tensors.emplace(name, std::move(t));
    FREELOC_CHECK(
        static_cast<int64_t>(f.tensors.size()) <= Limits().max_tensors,
        what << ": more than " << Limits().max_tensors << " tensors; refused (" << LimitHint("max_tensors") << ")");
  }
  // Names in file (data) order, as they were written.
  std::vector<Range> order = ranges;
  std::stable_sort(order.begin(), order.end(), [](const Range& a, const Range& b) { return a.begin < b.begin; });
  for (const auto& r : order) f.names.push_back(r.name);
  CheckTiling(ranges, data_size, bad, fix);
  return f;
}

SafetensorsFile SafetensorsFile::Open(const std::string& path) {
  auto m = MappedFile::Open(path);
  return Parse(m->data(), m->size(), m, path);
}

const TensorView& SafetensorsFile::Get(const std::string& name) const {
  auto it = tensors.find(name);
  FREELOC_CHECK(it != tensors.end(), path << ": no tensor named '" << name << "'");
  return it->second;
}

std::vector<uint8_t> SerializeSafetensors(const std::vector<std::pair<std::string, TensorView>>& tensors,
                                          const std::map<std::string, std::string>& metadata) {
  // nlohmann::ordered_json keeps insertion order so the header lists tensors in data order.
  nlohmann::ordered_json header = nlohmann::ordered_json::object();
  if (!metadata.empty()) {
    nlohmann::ordered_json m = nlohmann::ordered_json::object();
    for (const auto& [k, v] : metadata) m[k] = v;
    header["__metadata__"] = m;
  }
  uint64_t offset = 0;
  for (const auto& [name, t] : tensors) {
    FREELOC_CHECK(name != "__metadata__", "SerializeSafetensors: '__metadata__' is reserved");
    FREELOC_CHECK(!header.contains(name), "SerializeSafetensors: duplicate tensor name '" << name << "'");
    const uint64_t nb = static_cast<uint64_t>(t.numel()) * DTypeSize(t.dtype);
    FREELOC_CHECK(nb == t.nbytes, "SerializeSafetensors: tensor '" << name << "' has " << t.nbytes
                                                                   << " bytes for shape " << t.ShapeString());
    header[name] = {{"dtype", DTypeName(t.dtype)}, {"shape", t.shape}, {"data_offsets", {offset, offset + nb}}};
    offset += nb;
  }
  std::string h = header.dump();
  while (h.size() % 8 != 0) h.push_back(' ');
  std::vector<uint8_t> out(8 + h.size() + offset);
  const uint64_t n = h.size();
  for (int i = 0; i < 8; ++i) out[i] = static_cast<uint8_t>(n >> (8 * i));
  std::memcpy(out.data() + 8, h.data(), h.size());
  uint8_t* p = out.data() + 8 + h.size();
  for (const auto& [name, t] : tensors) {
    if (t.nbytes) std::memcpy(p, t.data, t.nbytes);
    p += t.nbytes;
  }
  return out;
}

void WriteSafetensors(const std::string& path, const std::vector<std::pair<std::string, TensorView>>& tensors,
                      const std::map<std::string, std::string>& metadata) {
  const auto bytes = SerializeSafetensors(tensors, metadata);
  WriteFileAtomic(path, bytes.data(), bytes.size());
}

}  // namespace freeloc::io

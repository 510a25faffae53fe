#include "freeloc/io/npz.h"

#include <zip.h>

#include <cstring>
#include <memory>

#include "freeloc/core/checked_math.h"
#include "freeloc/core/error.h"
#include "freeloc/core/limits.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/tensor.h"

namespace freeloc::io {

int64_t NpyArray::numel() const {
  int64_t n = 1;
  for (int64_t s : shape) n *= s;
  return n;
}

double NpyArray::at(std::initializer_list<int64_t> index) const {
  FREELOC_CHECK(index.size() == shape.size(),
                "NpyArray::at: " << index.size() << " indices for " << shape.size() << " dims");
  int64_t off = 0;
  size_t d = 0;
  for (int64_t i : index) {
    FREELOC_CHECK(i >= 0 && i < shape[d], "NpyArray::at: index out of range");
    off = off * shape[d] + i;
    ++d;
  }
  return data[static_cast<size_t>(off)];
}

namespace {

// Value of `key` in the header dict literal, as raw text up to the next top-level comma/brace.
std::string DictValue(const std::string& h, const std::string& key, const std::string& what) {
  size_t p = h.find("'" + key + "'");
  if (p == std::string::npos) p = h.find("\"" + key + "\"");
  FREELOC_CHECK(p != std::string::npos, what << ": .npy header has no '" << key << "'");
  p = h.find(':', p);
  FREELOC_CHECK(p != std::string::npos, what << ": malformed .npy header");
  ++p;
  while (p < h.size() && h[p] == ' ') ++p;
  int depth = 0;
  size_t e = p;
  for (; e < h.size(); ++e) {
    const char c = h[e];
    if (c == '(' || c == '[') ++depth;
    if (c == ')' || c == ']') --depth;
    if (depth == 0 && (c == ',' || c == '}')) break;
    if (depth < 0) break;
  }
  std::string v = h.substr(p, e - p + (h[e] == ')' ? 1 : 0));
  while (!v.empty() && v.back() == ' ') v.pop_back();
  return v;
}

// "(2, 3)", "(4,)", "()" → dimensions.
std::vector<int64_t> ParseShape(const std::string& shape, const std::string& what) {
  FREELOC_CHECK(shape.size() >= 2 && shape.front() == '(', what << ": malformed .npy shape " << shape);
  std::vector<int64_t> dims;
  std::string num;
  for (size_t i = 1; i < shape.size(); ++i) {
    const char c = shape[i];
    if (std::isdigit(static_cast<unsigned char>(c))) {
      num.push_back(c);
    } else if (c == ',' || c == ')') {
      FREELOC_CHECK(num.size() <= 18, what << ": .npy dimension " << num << " is absurdly large; the file is damaged");
      if (!num.empty()) dims.push_back(std::stoll(num));
      num.clear();
    } else if (c != ' ' && c != 'L') {
      FREELOC_THROW(what << ": malformed .npy shape " << shape);
    }
  }
  return dims;
}

// The dtype of a little-endian descr ("<f4", "|u1", …).
DType NpyDType(const std::string& descr, const std::string& what) {
  const char order = descr[0];
  FREELOC_CHECK(order == '<' || order == '|' || order == '=',
                what << ": .npy dtype " << descr << " is big-endian; only little-endian arrays are supported");
  static const std::pair<const char*, DType> kTypes[] = {
      {"f4", DType::kF32}, {"f8", DType::kF64}, {"f2", DType::kF16}, {"i8", DType::kI64}, {"i4", DType::kI32},
      {"i2", DType::kI16}, {"i1", DType::kI8},  {"u1", DType::kU8},  {"b1", DType::kBool}};
  for (const auto& [name, dt] : kTypes)
    if (descr.compare(1, std::string::npos, name) == 0) return dt;
  FREELOC_THROW(what << ": .npy dtype " << descr << " is not supported (float16/32/64, int8–64, uint8, bool)");
}

// Fortran order (the first index varies fastest) → C order.
std::vector<double> FortranToC(const std::vector<double>& raw, const std::vector<int64_t>& shape) {
  std::vector<double> out(raw.size());
  const size_t nd = shape.size();
  std::vector<int64_t> idx(nd, 0);
  for (size_t c = 0; c < raw.size(); ++c) {  // c walks C order
    int64_t f = 0;
    for (size_t d = nd; d-- > 0;) f = f * shape[d] + idx[d];
    out[c] = raw[static_cast<size_t>(f)];
    for (size_t d = nd; d-- > 0;) {
      if (++idx[d] < shape[d]) break;
      idx[d] = 0;
    }
  }
  return out;
}

}  // namespace

NpyArray ParseNpy(const uint8_t* b, size_t n, const std::string& what) {
  FREELOC_CHECK(n >= 10 && std::memcmp(b, "\x93NUMPY", 6) == 0, what << ": not a .npy array (bad magic)");
  const int major = b[6];
  size_t hlen, hstart;
  if (major == 1) {
    hlen = b[8] | (b[9] << 8);
    hstart = 10;
  } else {
    FREELOC_CHECK(major == 2 || major == 3, what << ": .npy format version " << major << " is not supported");
    FREELOC_CHECK(n >= 12, what << ": truncated .npy header");
    hlen = b[8] | (b[9] << 8) | (b[10] << 16) | (static_cast<size_t>(b[11]) << 24);
    hstart = 12;
  }
  FREELOC_CHECK(hstart + hlen <= n, what << ": .npy header runs past the end");
  const std::string h(reinterpret_cast<const char*>(b + hstart), hlen);
  NpyArray a;
  std::string descr = DictValue(h, "descr", what);
  FREELOC_CHECK(descr.size() >= 3 && (descr.front() == '\'' || descr.front() == '"'),
                what << ": .npy descr " << descr << " is not a simple dtype (structured arrays are not supported)");
  a.descr = descr.substr(1, descr.size() - 2);
  a.fortran_order = DictValue(h, "fortran_order", what) == "True";
  const std::string shape = DictValue(h, "shape", what);
  a.shape = ParseShape(shape, what);
  const DType dt = NpyDType(a.descr, what);
  const int64_t numel = CheckedNumel(a.shape, what);
  const size_t es = DTypeSize(dt);
  const size_t data_start = hstart + hlen;
  const int64_t need = CheckedMul(numel, static_cast<int64_t>(es), what);
  FREELOC_CHECK(static_cast<uint64_t>(need) <= n - data_start, what << ": .npy data holds " << (n - data_start)
                                                                    << " bytes, shape needs " << need
                                                                    << "; the file is truncated");
  // Values are held as doubles: a 1-byte dtype costs 8x its file size, so the element count is bounded too.
  FREELOC_CHECK(numel <= Limits().max_zip_member_bytes / 8,
                what << ": " << numel << " elements would take " << numel * 8 << " bytes as doubles, beyond the "
                     << LimitHint("max_zip_member_bytes") << " (/ 8 per element)");
  TensorView view;
  view.dtype = dt;
  view.shape = a.shape;
  view.data = b + data_start;
  view.nbytes = static_cast<size_t>(numel) * es;
  std::vector<double> raw = view.ToDouble();
  a.data = a.fortran_order && a.shape.size() > 1 ? FortranToC(raw, a.shape) : std::move(raw);
  return a;
}

std::map<std::string, NpyArray> ReadNpz(const std::string& path) {
  const auto file = MappedFile::Open(path);
  FREELOC_CHECK(file->size() >= 4 && file->data()[0] == 'P' && file->data()[1] == 'K',
                path << ": not an .npz archive (expected a zip of .npy arrays)");
  zip_error_t zerr;
  zip_error_init(&zerr);
  zip_source_t* src = zip_source_buffer_create(file->data(), file->size(), 0, &zerr);
  FREELOC_CHECK(src, path << ": cannot read as zip");
  zip_t* z = zip_open_from_source(src, ZIP_RDONLY, &zerr);
  if (!z) {
    zip_source_free(src);
    zip_error_fini(&zerr);
    FREELOC_THROW(path << ": damaged .npz archive");
  }
  std::unique_ptr<zip_t, void (*)(zip_t*)> guard(z, [](zip_t* p) { zip_discard(p); });
  std::map<std::string, NpyArray> out;
  const zip_int64_t entries = zip_get_num_entries(z, 0);
  FREELOC_CHECK(entries <= Limits().max_tensors,
                path << ": " << entries << " arrays; refused (" << LimitHint("max_tensors") << ")");
  uint64_t expanded = 0;
  for (zip_int64_t i = 0; i < entries; ++i) {
    const char* raw_name = zip_get_name(z, i, 0);
    FREELOC_CHECK(raw_name, path << ": member " << i << " has no readable name; the archive is damaged");
    std::string name = raw_name;
    zip_stat_t st;
    zip_stat_init(&st);
    FREELOC_CHECK(zip_stat_index(z, i, 0, &st) == 0, path << ": member " << SafeText(name) << " is damaged");
    CheckZipMemberSize(st.size, st.comp_size, st.comp_method == ZIP_CM_STORE, path + ": member " + SafeText(name));
    if (st.comp_method != ZIP_CM_STORE) expanded += st.size;
    FREELOC_CHECK(expanded <= static_cast<uint64_t>(Limits().max_zip_member_bytes),
                  path << ": compressed members expand to more than " << Limits().max_zip_member_bytes
                       << " bytes in all; refused (" << LimitHint("max_zip_member_bytes") << ")");
    std::vector<uint8_t> buf(st.size);
    zip_file_t* f = zip_fopen_index(z, i, 0);
    FREELOC_CHECK(f, path << ": cannot open member " << name);
    const zip_int64_t got = st.size ? zip_fread(f, buf.data(), st.size) : 0;
    zip_fclose(f);
    FREELOC_CHECK(got == static_cast<zip_int64_t>(st.size), path << ": member " << name << " is truncated");
    if (name.size() > 4 && name.compare(name.size() - 4, 4, ".npy") == 0) name.resize(name.size() - 4);
    out[name] = ParseNpy(buf.data(), buf.size(), path + ":" + name);
  }
  return out;
}

}  // namespace freeloc::io

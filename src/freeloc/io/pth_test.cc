#include "freeloc/io/pth.h"

#include <gtest/gtest.h>
#include <zip.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "freeloc/core/error.h"
#include "freeloc/io/checkpoint.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/safetensors.h"
#include "testing/pth_builder.h"
#include "testing/testing.h"

namespace freeloc::io {
namespace {

using testing::SharedPath;

std::string ErrorOf(const std::string& path) {
  try {
    PthFile::Open(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// A well-formed zip checkpoint written by the test itself (testing/pth_builder.h): four float storages of 6 values,
// one 2×3 tensor each, under archive/.
std::string BuiltCheckpoint(const testing::TempDir& tmp) {
  testing::PthSpec spec;
  for (int k = 0; k < 4; ++k) {
    const std::string key = std::to_string(k);
    spec.storages.push_back({key, "FloatStorage", 6, 24});
    spec.tensors.push_back({"w" + key, key, 0, {2, 3}, {3, 1}});
  }
  const std::string path = tmp.File("built.pth");
  testing::WritePthSpec(path, spec);
  return path;
}

// Copies a zip, dropping the entry `skip` and replacing `replace_name`'s content with `replace_bytes`.
void RewriteZip(const std::string& src, const std::string& dst, const std::string& skip,
                const std::string& replace_name = "", const std::string& replace_bytes = "") {
  int err = 0;
  zip_t* in = zip_open(src.c_str(), ZIP_RDONLY, &err);
  ASSERT_NE(in, nullptr);
  zip_t* out = zip_open(dst.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
  ASSERT_NE(out, nullptr);
  std::vector<std::string> keep;  // buffers must outlive zip_close
  keep.reserve(64);
  for (zip_int64_t i = 0; i < zip_get_num_entries(in, 0); ++i) {
    const std::string name = zip_get_name(in, i, 0);
    if (name == skip) continue;
    std::string data;
    if (name == replace_name) {
      data = replace_bytes;
    } else {
      zip_stat_t st;
      zip_stat_index(in, i, 0, &st);
      data.resize(st.size);
      zip_file_t* f = zip_fopen_index(in, i, 0);
      zip_fread(f, data.data(), st.size);
      zip_fclose(f);
    }
    keep.push_back(data);
    zip_source_t* s = zip_source_buffer(out, keep.back().data(), keep.back().size(), 0);
    zip_file_add(out, name.c_str(), s, ZIP_FL_OVERWRITE);
  }
  ASSERT_EQ(zip_close(out), 0);
  zip_close(in);
}

TEST(Pth, FormatsFixtureMatchesDescription) {
  FREELOC_REQUIRE_SHARED("fixtures/pth/formats.pth");
  std::ifstream jf(SharedPath("fixtures/pth/formats.json"));
  const nlohmann::json spec = nlohmann::json::parse(jf);
  const Checkpoint ckpt = Checkpoint::Open(SharedPath("fixtures/pth/formats.pth"));
  const PthFile pth = PthFile::Open(SharedPath("fixtures/pth/formats.pth"));
  const std::string under = spec["tensors_under"];
  ASSERT_EQ(spec["tensors"].size(), 12u);
  for (auto it = spec["tensors"].begin(); it != spec["tensors"].end(); ++it) {
    SCOPED_TRACE(it.key());
    const auto& e = it.value();
    const TensorView& t = ckpt.Get(under + "." + it.key());
    EXPECT_EQ(DTypeTorchName(t.dtype), e["dtype"].get<std::string>());
    EXPECT_EQ(t.shape, e["shape"].get<std::vector<int64_t>>());
    const auto v = t.ToDouble();
    double sum = 0;
    for (double x : v) sum += x;
    EXPECT_NEAR(sum, e["sum"].get<double>(), 1e-5 * (1 + std::abs(e["sum"].get<double>())));
    if (!e["first"].is_null()) {
      EXPECT_EQ(v.front(), e["first"].get<double>());
      EXPECT_EQ(v.back(), e["last"].get<double>());
    } else {
      EXPECT_TRUE(v.empty());
    }
    // Contiguity as stored: the tensor node's index into pth.tensors.
    const PyRef node = pth.root->Find(under + "." + it.key());
    ASSERT_TRUE(node && node->is(PyObject::Kind::kTensor));
    EXPECT_EQ(static_cast<bool>(pth.was_contiguous[node->i]), e["contiguous"].get<bool>());
  }
  // view_a and view_b are two views (offsets 5 and 20, the latter strided) of one shared storage; their
  // sums/first/last above prove the offsets and strides were honoured.
  // Values.
  const PyRef root = ckpt.root();
  for (auto it = spec["values"].begin(); it != spec["values"].end(); ++it) {
    SCOPED_TRACE(it.key());
    const PyRef v = root->Find(it.key());
    ASSERT_TRUE(v) << it.key();
    const auto& e = it.value();
    if (e.is_number_integer()) {
      ASSERT_TRUE(v->is(PyObject::Kind::kInt));
      EXPECT_EQ(v->i, e.get<int64_t>());
    } else if (e.is_number_float()) {
      EXPECT_EQ(v->f, e.get<double>());
    } else if (e.is_string()) {
      EXPECT_EQ(v->s, e.get<std::string>());
    } else if (e.is_array()) {
      // Compare the repr of lists/tuples against JSON spelled Python-style.
      ASSERT_TRUE(v->is(PyObject::Kind::kList) || v->is(PyObject::Kind::kTuple));
      EXPECT_EQ(v->items.size(), e.size());
    }
  }
  EXPECT_EQ(root->Find("nested.list")->Repr(), "[1, 2.5, 'three', None, True]");
  EXPECT_EQ(root->Find("nested.tuple")->Repr(), "(4, (5, 6))");
  // Opaque object: argparse.Namespace with readable fields.
  const auto& op = spec["opaque"]["args"];
  const PyRef args = root->Get("args");
  ASSERT_TRUE(args && args->is(PyObject::Kind::kObject));
  EXPECT_EQ(args->module + "." + args->name, op["class"].get<std::string>());
  EXPECT_EQ(args->Get("model")->s, op["model"].get<std::string>());
  EXPECT_EQ(args->Get("lr")->f, op["lr"].get<double>());
  EXPECT_EQ(args->Get("epochs")->i, op["epochs"].get<int64_t>());
  EXPECT_EQ(ckpt.metadata().at("args.model"), op["model"].get<std::string>());
  EXPECT_EQ(ckpt.metadata().at("nested.big"), "1099511627776");
}

TEST(Pth, Dust3rTinyIdenticalToSafetensors) {
  FREELOC_REQUIRE_SHARED("fixtures/pth/dust3r_tiny.pth");
  FREELOC_REQUIRE_SHARED("fixtures/dust3r/weights.safetensors");
  const Checkpoint pth = Checkpoint::Open(SharedPath("fixtures/pth/dust3r_tiny.pth"));
  const Checkpoint st = Checkpoint::Open(SharedPath("fixtures/dust3r/weights.safetensors"));
  EXPECT_EQ(pth.format(), Checkpoint::Format::kPth);
  EXPECT_EQ(st.format(), Checkpoint::Format::kSafetensors);
  const auto sd = pth.StateDict();
  EXPECT_EQ(pth.StateDictRoot(), "model");
  ASSERT_EQ(sd.size(), 745u);
  ASSERT_EQ(st.size(), 745u);
  for (const auto& name : st.names()) {
    SCOPED_TRACE(name);
    ASSERT_TRUE(sd.count(name));
    const TensorView& a = sd.at(name);
    const TensorView& b = st.Get(name);
    EXPECT_EQ(a.dtype, b.dtype);
    EXPECT_EQ(a.shape, b.shape);
    ASSERT_EQ(a.nbytes, b.nbytes);
    EXPECT_EQ(std::memcmp(a.data, b.data, a.nbytes), 0);
  }
  std::ifstream jf(SharedPath("fixtures/pth/formats.json"));
  const nlohmann::json spec = nlohmann::json::parse(jf);
  EXPECT_EQ(pth.MetadataOr("args.model", ""), spec["dust3r_tiny"]["args.model"].get<std::string>());
}

TEST(Pth, LegacyFormatRefusedByName) {
  // torch.save(..., _use_new_zipfile_serialization=False): a bare pickle stream that starts with the legacy magic
  // number 0x1950a86a20f9469cfc6c (LONG1).
  testing::TempDir tmp;
  const std::string path = tmp.File("legacy_format.pth");
  testing::WriteText(path, std::string("\x80\x02\x8a\x0a\x6c\xfc\x9c\x46\xf9\x20\x6a\xa8\x50\x19.", 15));
  const std::string m = ErrorOf(path);
  EXPECT_NE(m.find("legacy (non-zip) PyTorch checkpoint format"), std::string::npos) << m;
  EXPECT_NE(m.find("legacy_format.pth"), std::string::npos) << m;
}

TEST(Pth, MissingStorageRecord) {
  testing::TempDir tmp;
  const std::string built = BuiltCheckpoint(tmp);
  EXPECT_EQ(ErrorOf(built), "");
  const std::string dst = tmp.File("broken.pth");
  RewriteZip(built, dst, "archive/data/3");
  const std::string m = ErrorOf(dst);
  EXPECT_NE(m.find("storage record 'archive/data/3' is missing"), std::string::npos) << m;
  EXPECT_NE(m.find("broken.pth"), std::string::npos) << m;
}

TEST(Pth, ShortStorageRecord) {
  testing::TempDir tmp;
  const std::string dst = tmp.File("short.pth");
  RewriteZip(BuiltCheckpoint(tmp), dst, "", "archive/data/0", std::string(8, '\0'));
  const std::string m = ErrorOf(dst);
  EXPECT_NE(m.find("holds 8 bytes"), std::string::npos) << m;
}

TEST(Pth, UnsupportedOpcodeNamed) {
  testing::TempDir tmp;
  const std::string built = BuiltCheckpoint(tmp);
  const std::string dst = tmp.File("evil.pth");
  RewriteZip(built, dst, "", "archive/data.pkl",
             std::string("\x80\x02(cos\nsystem\nX\x02\x00\x00\x00lsi__main__\nX\n.", 34));
  const std::string m = ErrorOf(dst);
  EXPECT_NE(m.find("global os.system"), std::string::npos) << m;  // refused by the allow-list first
  EXPECT_NE(m.find("evil.pth/archive/data.pkl"), std::string::npos) << m;
  RewriteZip(built, dst, "", "archive/data.pkl", std::string("\x80\x02(X\x02\x00\x00\x00lsi__main__\nX\n.", 24));
  EXPECT_NE(ErrorOf(dst).find("(INST)"), std::string::npos) << ErrorOf(dst);
}

// A checkpoint laid out as training code saves it ({'model': state dict, 'args': Namespace}), written with real
// values by testing/pth_builder.h, reads back tensor for tensor and with its constructor string.
TEST(Pth, StateDictUnderModelWithArgsRoundTrips) {
  testing::TempDir tmp;
  std::vector<testing::PthFloatTensor> tensors = {
      {"enc.weight", {3, 4}, {}}, {"enc.bias", {3}, {}}, {"head.w", {2, 1, 2}, {}}};
  float x = 0.25f;
  for (auto& t : tensors) {
    int64_t n = 1;
    for (int64_t d : t.shape) n *= d;
    for (int64_t i = 0; i < n; ++i) t.values.push_back(x += 0.5f);
  }
  const std::string ctor = "AsymmetricCroCo3DStereo(enc_embed_dim=64, depth_mode=('exp', -inf, inf))";
  testing::WriteStateDictPth(tmp.File("sd.pth"), tensors, {{"model", ctor}, {"note", "x"}});
  const Checkpoint ckpt = Checkpoint::Open(tmp.File("sd.pth"));
  EXPECT_EQ(ckpt.StateDictRoot(), "model");
  EXPECT_EQ(ckpt.MetadataOr("args.model", ""), ctor);
  EXPECT_EQ(ckpt.MetadataOr("args.note", ""), "x");
  const auto sd = ckpt.StateDict();
  ASSERT_EQ(sd.size(), tensors.size());
  for (const auto& t : tensors) {
    SCOPED_TRACE(t.name);
    ASSERT_TRUE(sd.count(t.name));
    EXPECT_EQ(sd.at(t.name).shape, t.shape);
    const auto v = sd.at(t.name).ToDouble();
    ASSERT_EQ(v.size(), t.values.size());
    for (size_t i = 0; i < v.size(); ++i) EXPECT_EQ(v[i], static_cast<double>(t.values[i]));
  }
}

TEST(Pth, NotACheckpoint) {
  testing::TempDir tmp;
  testing::WriteText(tmp.File("a.pth"), "hello world, not a checkpoint");
  EXPECT_NE(ErrorOf(tmp.File("a.pth")).find("not a PyTorch checkpoint"), std::string::npos);
  testing::WriteText(tmp.File("b.pth"), "PK\x03\x04 truncated zip");
  EXPECT_NE(ErrorOf(tmp.File("b.pth")).find("b.pth"), std::string::npos);
  EXPECT_NE(ErrorOf(tmp.File("missing.pth")).find("missing.pth"), std::string::npos);
}

}  // namespace
}  // namespace freeloc::io

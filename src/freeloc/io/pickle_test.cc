#include "freeloc/io/pickle.h"

#include <gtest/gtest.h>

#include "freeloc/core/error.h"

// Byte strings with embedded NULs: the literal's full size.
#define BYTES(lit) std::string(lit, sizeof(lit) - 1)

namespace freeloc::io {
namespace {

// BINUNICODE: 'X', the UTF-8 length as 4 little-endian bytes, the text.
std::string Unicode(const std::string& text) {
  const uint32_t n = static_cast<uint32_t>(text.size());
  return std::string("X") + static_cast<char>(n & 0xff) + static_cast<char>((n >> 8) & 0xff) +
         static_cast<char>((n >> 16) & 0xff) + static_cast<char>(n >> 24) + text;
}

PyRef Parse(const std::string& bytes) {
  return ParsePickle(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), "test.pkl", nullptr);
}

std::string ErrorOf(const std::string& bytes) {
  try {
    Parse(bytes);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Pickle, ScalarsAndContainers) {
  // {'a': [1, -7, 2.5, None, True], 'b': ('x', 300)}  — protocol 2 as CPython writes it.
  const std::string p = BYTES("\x80\x02}q\x00(") + Unicode("a") +
                        BYTES(
                            "]q\x01(K\x01J\xf9\xff\xff\xffG\x40\x04\x00\x00\x00\x00\x00\x00N\x88"
                            "e") +
                        Unicode("b") + Unicode("x") + BYTES("M\x2c\x01\x86u.");
  PyRef r = Parse(p);
  ASSERT_TRUE(r->is(PyObject::Kind::kDict));
  PyRef a = r->Get("a");
  ASSERT_TRUE(a && a->is(PyObject::Kind::kList));
  ASSERT_EQ(a->items.size(), 5u);
  EXPECT_EQ(a->items[0]->i, 1);
  EXPECT_EQ(a->items[1]->i, -7);
  EXPECT_EQ(a->items[2]->f, 2.5);
  EXPECT_TRUE(a->items[3]->is(PyObject::Kind::kNone));
  EXPECT_TRUE(a->items[4]->b);
  PyRef b = r->Get("b");
  ASSERT_TRUE(b->is(PyObject::Kind::kTuple));
  EXPECT_EQ(b->items[0]->s, "x");
  EXPECT_EQ(b->items[1]->i, 300);
  EXPECT_EQ(r->Find("a.2")->f, 2.5);
  EXPECT_EQ(r->Find("b.1")->i, 300);
  EXPECT_EQ(r->Find("a.9"), nullptr);
  EXPECT_EQ(r->Repr(), "{'a': [1, -7, 2.5, None, True], 'b': ('x', 300)}");
}

TEST(Pickle, BigAndNegativeLongs) {
  // LONG1 of 9 bytes: 2**64 + 5, and LONG1 -2**63 (8 bytes), and LONG1 of 1 byte 0xff = -1.
  const std::string p = BYTES(
      "\x80\x02(\x8a\x09\x05\x00\x00\x00\x00\x00\x00\x00\x01"
      "\x8a\x08\x00\x00\x00\x00\x00\x00\x00\x80"
      "\x8a\x01\xff"
      "\x8a\x09\xfb\xff\xff\xff\xff\xff\xff\xff\xfe"
      "l.");
  PyRef r = Parse(p);
  ASSERT_EQ(r->items.size(), 4u);
  EXPECT_TRUE(r->items[0]->is(PyObject::Kind::kBigInt));
  EXPECT_EQ(r->items[0]->s, "18446744073709551621");
  EXPECT_EQ(r->items[1]->i, INT64_MIN);
  EXPECT_EQ(r->items[2]->i, -1);
  EXPECT_EQ(r->items[3]->s, "-18446744073709551621");
}

TEST(Pickle, OpaqueObjectKeepsState) {
  // argparse.Namespace(model='Net()', lr=0.5) via NEWOBJ + BUILD.
  const std::string p = BYTES(
                            "\x80\x02"
                            "cargparse\nNamespace\n)\x81}(") +
                        Unicode("model") + Unicode("Net()") + Unicode("lr") +
                        BYTES("G\x3f\xe0\x00\x00\x00\x00\x00\x00ub.");
  PyRef r = Parse(p);
  ASSERT_TRUE(r->is(PyObject::Kind::kObject));
  EXPECT_EQ(r->module, "argparse");
  EXPECT_EQ(r->name, "Namespace");
  EXPECT_EQ(r->Get("model")->s, "Net()");
  EXPECT_EQ(r->Get("lr")->f, 0.5);
  EXPECT_EQ(r->Repr(), "argparse.Namespace(model='Net()', lr=0.5)");
}

TEST(Pickle, DuplicateKeysLastWins) {
  const std::string p = BYTES("\x80\x02}(X\x01\x00\x00\x00kK\x01X\x01\x00\x00\x00kK\x02u.");
  PyRef r = Parse(p);
  ASSERT_EQ(r->dict.size(), 1u);
  EXPECT_EQ(r->Get("k")->i, 2);
}

TEST(Pickle, UnsupportedOpcodeIsNamed) {
  // INST ('i') instantiates arbitrary classes in protocol 0 — never executed, refused by name.
  const std::string m = ErrorOf(BYTES("\x80\x02(i__main__\nEvil\n."));
  EXPECT_NE(m.find("opcode 0x69 (INST)"), std::string::npos) << m;
  EXPECT_NE(m.find("test.pkl"), std::string::npos) << m;
  EXPECT_NE(ErrorOf("\x80\x02"
                    "F1.0\n.")
                .find("(FLOAT)"),
            std::string::npos);
  EXPECT_NE(ErrorOf(BYTES("\x80\x02\xfe")).find("0xfe (unknown)"), std::string::npos);
}

TEST(Pickle, DamagedStreams) {
  EXPECT_NE(ErrorOf(BYTES("\x80\x02}")).find("without STOP"), std::string::npos);
  EXPECT_NE(ErrorOf(BYTES("\x80\x02X\x10\x00\x00\x00"
                          "ab"))
                .find("truncated"),
            std::string::npos);
  EXPECT_NE(ErrorOf(BYTES("\x80\x02h\x05.")).find("memo entry 5"), std::string::npos);
  EXPECT_NE(ErrorOf(BYTES("\x80\x02"
                          "t."))
                .find("MARK missing"),
            std::string::npos);
  EXPECT_NE(ErrorOf(BYTES("\x80\x02"
                          "0."))
                .find("underflow"),
            std::string::npos);
  // Persistent id without a loader.
  EXPECT_NE(ErrorOf(BYTES("\x80\x02NQ.")).find("no loader"), std::string::npos);
}

}  // namespace
}  // namespace freeloc::io

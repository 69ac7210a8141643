// UTF-8 checks: what is valid passes unchanged; every invalid form is found and escaped so that
// the original bytes can be read back.

#include "multibond/core/utf8.h"

#include <string>

#include <gtest/gtest.h>

namespace multibond {
namespace {

TEST(Utf8, ValidTextIsValidAndUnchanged) {
  for (const std::string s : {"", "plain", "µm, °, Ω", "\xF0\x9F\x98\x80 (U+1F600)", "back\\slash"}) {
    EXPECT_EQ(FindInvalidUtf8(s), std::string::npos) << s;
    EXPECT_EQ(EscapeInvalidUtf8(s), s);
  }
}

TEST(Utf8, EveryInvalidFormIsFoundAtItsFirstByte) {
  EXPECT_EQ(FindInvalidUtf8("caf\xE9"), 3u);             // Latin-1
  EXPECT_EQ(FindInvalidUtf8("a\xC0\xAF"), 1u);           // overlong '/'
  EXPECT_EQ(FindInvalidUtf8("a\xE0\x80\xAF"), 1u);       // overlong, three bytes
  EXPECT_EQ(FindInvalidUtf8("ab\xED\xA0\x80"), 2u);      // a surrogate
  EXPECT_EQ(FindInvalidUtf8("\xF4\x90\x80\x80"), 0u);    // above U+10FFFF
  EXPECT_EQ(FindInvalidUtf8("x\xE2\x82"), 1u);           // cut short
  EXPECT_EQ(FindInvalidUtf8("\x80"), 0u);                // a lone continuation byte
  EXPECT_EQ(FindInvalidUtf8("ok\xFF"), 2u);
}

TEST(Utf8, InvalidBytesAreEscapedRecoverably) {
  EXPECT_EQ(EscapeInvalidUtf8("caf\xE9.yaml"), "caf\\xE9.yaml");
  // A backslash beside an escape is doubled, so "\xE9" typed as text is not read as a byte.
  EXPECT_EQ(EscapeInvalidUtf8("a\\xE9\xFF"), "a\\\\xE9\\xFF");
  EXPECT_EQ(EscapeInvalidUtf8("\xC3\xA9\xC3"), "\xC3\xA9\\xC3");
}

}  // namespace
}  // namespace multibond

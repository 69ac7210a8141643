// The escaping functions of safe_text.h, one per interpreter: whatever bytes come in, what comes
// out cannot end its string, line or statement, holds no control character and is valid UTF-8.
#include "multibond/io/safe_text.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace multibond {
namespace {

const std::string kFffd = "\xef\xbf\xbd";

/// Inputs that try every way out: quotes, backquotes, macros, line breaks, escapes, bytes that are
/// not UTF-8 (a stray continuation byte, a truncated, an overlong and a surrogate sequence).
const std::vector<std::string> kHostile = {
    "plain", "it's \"quoted\"", "`touch x`", "@macro", "a\nsystem \"x\"\n!x", "end\\", "c\r\x01\x1b[2J\x7f\xc2\x85",
    "\x80", "\xe2\x82", "\xc0\xaf", "\xed\xa0\x80", "</script><script>alert(1)</script>", "\xf4\x90\x80\x80", std::string("nul\0x", 5),
};

bool ValidUtf8NoControls(const std::string& s, bool newline_ok) {
  for (size_t i = 0; i < s.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if ((c < 0x20 && !(newline_ok && (c == '\n' || c == '\t'))) || c == 0x7f) return false;
    if (c == 0xc2 && i + 1 < s.size() && static_cast<unsigned char>(s[i + 1]) < 0xa0) return false;  // C1
  }
  return ValidUtf8(s) == s;
}

TEST(SafeText, ValidUtf8ReplacesWhatIsNotUtf8) {
  EXPECT_EQ(ValidUtf8("a\xffz"), "a" + kFffd + "z");
  EXPECT_EQ(ValidUtf8("\xc0\xaf"), kFffd + kFffd);  // overlong '/'
  EXPECT_EQ(ValidUtf8("\xed\xa0\x80"), kFffd + kFffd + kFffd);  // surrogate
  EXPECT_EQ(ValidUtf8("\xe2\x82"), kFffd + kFffd);  // truncated
  EXPECT_EQ(ValidUtf8("µm, \xe2\x82\xac, \xf0\x9f\x98\x80"), "µm, \xe2\x82\xac, \xf0\x9f\x98\x80");
  EXPECT_EQ(ValidUtf8("a\tb\nc\x01"), "a\tb\nc" + kFffd);
}

TEST(SafeText, HtmlEscapeLeavesNoMarkup) {
  EXPECT_EQ(HtmlEscape("</script><script>alert('x' & \"y\")</script>"),
            "&lt;/script&gt;&lt;script&gt;alert(&#39;x&#39; &amp; &quot;y&quot;)&lt;/script&gt;");
  for (const std::string& s : kHostile) {
    const std::string out = HtmlEscape(s);
    EXPECT_EQ(out.find_first_of("<>\"'"), std::string::npos) << out;
    EXPECT_TRUE(ValidUtf8NoControls(out, true)) << out;
  }
}

TEST(SafeText, GnuplotStringIsOneSingleQuotedLiteral) {
  EXPECT_EQ(GnuplotString("it's"), "'it''s'");
  EXPECT_EQ(GnuplotString("a\nb"), "'a b'");
  EXPECT_EQ(GnuplotString("`x`"), "'" + kFffd + "x" + kFffd + "'");
  EXPECT_EQ(GnuplotString("@m \"q\" \\"), "'@m \"q\" \\'");  // inert inside single quotes
  for (const std::string& s : kHostile) {
    const std::string out = GnuplotString(s);
    ASSERT_GE(out.size(), 2u);
    EXPECT_EQ(out.front(), '\'');
    EXPECT_EQ(out.back(), '\'');
    // Inside, every quote is doubled: the literal ends only at its last character.
    const std::string body = out.substr(1, out.size() - 2);
    for (size_t i = 0; i < body.size(); ++i)
      if (body[i] == '\'') {
        ASSERT_LT(i + 1, body.size()) << out;
        EXPECT_EQ(body[++i], '\'') << out;
      }
    EXPECT_EQ(out.find('`'), std::string::npos) << out;
    EXPECT_TRUE(ValidUtf8NoControls(out, false)) << out;
  }
}

TEST(SafeText, GnuplotLiteralTextEscapesEnhancedMarkup) {
  EXPECT_EQ(GnuplotLiteralText("m^2 {/=99 x}_a&b~c@d\\"), "m\\^2 \\{/=99 x\\}\\_a\\&b\\~c\\@d\\\\");
}

TEST(SafeText, GnuplotCommentStaysOnItsLine) {
  EXPECT_EQ(GnuplotComment("s\n!rm x\\"), "s !rm x");
  for (const std::string& s : kHostile) {
    const std::string out = GnuplotComment(s);
    EXPECT_EQ(out.find('`'), std::string::npos) << out;
    EXPECT_TRUE(out.empty() || out.back() != '\\') << out;
    EXPECT_TRUE(ValidUtf8NoControls(out, false)) << out;
  }
}

TEST(SafeText, DotStringAndHtmlLabel) {
  EXPECT_EQ(DotString("a\"]; x [image=\"/etc/passwd\"]"), "\"a\\\"]; x [image=\\\"/etc/passwd\\\"]\"");
  EXPECT_EQ(DotString("back\\slash\nline\r"), "\"back\\\\slash\\nline\"");
  EXPECT_EQ(DotHtmlText("<b>&'\"\n"), "&lt;b&gt;&amp;&#39;&quot;<BR/>");
  for (const std::string& s : kHostile) {
    const std::string out = DotString(s);
    // No unescaped quote inside.
    for (size_t i = 1; i + 1 < out.size(); ++i) {
      if (out[i] == '\\') ++i;
      else EXPECT_NE(out[i], '"') << out;
    }
    EXPECT_TRUE(ValidUtf8NoControls(out, false)) << out;
    EXPECT_EQ(DotHtmlText(s).find_first_of("<>\"'"), DotHtmlText(s).find("<BR/>")) << DotHtmlText(s);
  }
}

TEST(SafeText, MessageTextShowsBytesInsteadOfEscapes) {
  EXPECT_EQ(MessageText("a\x1b[2Jb\xff\nc\xc2\x9b"), "a\\x1b[2Jb\\xff\nc\\xc2\\x9b");
  EXPECT_EQ(MessageText("µm"), "µm");
}

}  // namespace
}  // namespace multibond

// SHA-256 against the FIPS 180-2 test vectors, in one piece and in increments.

#include "multibond/core/sha256.h"

#include <string>

#include <gtest/gtest.h>

namespace multibond {
namespace {

TEST(Sha256, KnownVectors) {
  EXPECT_EQ(Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(Sha256Hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}

TEST(Sha256, IncrementsGiveTheDigestOfTheWholeAndTheHashGoesOn) {
  Sha256 h;
  const std::string million_a(1000000, 'a');
  for (size_t i = 0; i < million_a.size(); i += 4096) h.Update(std::string_view(million_a).substr(i, 4096));
  EXPECT_EQ(h.HexDigest(), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  h.Update("");
  EXPECT_EQ(h.HexDigest(), Sha256Hex(million_a));  // reading the digest does not end the hash
}

}  // namespace
}  // namespace multibond

// SHA-256 against FIPS 180-4's examples, split updates, and a file.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "scene/atomic_file.h"
#include "scene/sha256.h"

#include <string>

using namespace icube;

TEST_CASE("sha256: the FIPS 180-4 examples, any split of the input, and files") {
  CHECK(scene::sha256_hex("") == "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  CHECK(scene::sha256_hex("abc") == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  const std::string two = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";  // 448 bits: padding spills a block
  CHECK(scene::sha256_hex(two) == "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  const std::string million(1000000, 'a');
  CHECK(scene::sha256_hex(million) == "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  for (size_t cut : {size_t(1), size_t(55), size_t(63), size_t(64), size_t(65), size_t(999999)}) {
    scene::Sha256 h;
    h.update(million.data(), cut);
    h.update(million.data() + cut, million.size() - cut);
    CHECK(h.hex() == "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  }
  test::TempDir dir("sha");
  const std::string path = (dir.path / "a.bin").string();
  scene::write_file_atomic(path, million);
  CHECK(scene::sha256_file(path) == "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  CHECK_THROWS_WITH(scene::sha256_file((dir.path / "missing").string()), doctest::Contains("cannot read"));
}

// CURVE key files: generation, the .key/.pub files and the authorised-clients file, with
// every malformed input refused by name.
#include "common/keys/keys.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

class KeysTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("sceneloc_keys_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Write(const std::string& name, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path) << text;
    return path;
  }

  fs::path dir_;
};

TEST_F(KeysTest, DebianLibzmqHasCurve) { EXPECT_TRUE(CurveAvailable()); }

TEST_F(KeysTest, GeneratedPairsWriteAndReadBack) {
  auto pair = GenerateKeyPair("robot-7");
  ASSERT_TRUE(pair.ok()) << pair.status().ToString();
  EXPECT_EQ(pair->public_key.size(), kZ85KeyLength);
  EXPECT_TRUE(IsZ85Key(pair->public_key));
  EXPECT_TRUE(IsZ85Key(pair->secret_key));
  EXPECT_NE(GenerateKeyPair("robot-7")->public_key, pair->public_key);  // fresh each time

  ASSERT_TRUE(WriteKeyPair(*pair, dir_.string(), false).ok());
  struct stat st {};
  ASSERT_EQ(::stat((dir_ / "robot-7.key").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u) << "the secret key must be readable by its owner only";

  auto secret = ReadKeyFile((dir_ / "robot-7.key").string(), true);
  ASSERT_TRUE(secret.ok()) << secret.status().ToString();
  EXPECT_EQ(secret->name, "robot-7");
  EXPECT_EQ(secret->public_key, pair->public_key);
  EXPECT_EQ(secret->secret_key, pair->secret_key);

  auto pub = ReadKeyFile((dir_ / "robot-7.pub").string(), false);
  ASSERT_TRUE(pub.ok()) << pub.status().ToString();
  EXPECT_EQ(pub->public_key, pair->public_key);
  EXPECT_TRUE(pub->secret_key.empty());
  const Status needs_secret = ReadKeyFile((dir_ / "robot-7.pub").string(), true).status();
  EXPECT_EQ(needs_secret.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(needs_secret.message().find("no secret_key"), std::string::npos)
      << needs_secret.message();

  // Never overwritten by accident.
  const Status again = WriteKeyPair(*GenerateKeyPair("robot-7"), dir_.string(), false);
  EXPECT_EQ(again.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(ReadKeyFile((dir_ / "robot-7.key").string(), true)->secret_key, pair->secret_key);
  EXPECT_TRUE(WriteKeyPair(*GenerateKeyPair("robot-7"), dir_.string(), true).ok());
  EXPECT_NE(ReadKeyFile((dir_ / "robot-7.key").string(), true)->secret_key, pair->secret_key);
}

TEST_F(KeysTest, BadNamesAndFilesAreRefusedByName) {
  for (const char* name : {"", ".hidden", "a/b", "robot 7", "../x"}) {
    EXPECT_EQ(GenerateKeyPair(name).status().code(), StatusCode::kInvalidArgument) << name;
  }
  EXPECT_EQ(ReadKeyFile((dir_ / "missing.key").string(), true).status().code(),
            StatusCode::kNotFound);
  const KeyPair a = *GenerateKeyPair("a");
  const KeyPair b = *GenerateKeyPair("b");
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"not YAML", "name: [unclosed"},
      {"a list", "- 1\n- 2\n"},
      {"short key", "name: a\npublic_key: \"abc\"\nsecret_key: \"" + a.secret_key + "\"\n"},
      {"not Z85", "name: a\npublic_key: \"" + std::string(40, '"') + "\"\n"},
      {"mismatched pair",
       "name: a\npublic_key: \"" + b.public_key + "\"\nsecret_key: \"" + a.secret_key + "\"\n"},
      {"no public key", "name: a\nsecret_key: \"" + a.secret_key + "\"\n"},
  };
  for (const auto& [what, text] : bad) {
    const std::string path = Write("bad.key", text);
    const Status status = ReadKeyFile(path, true).status();
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << what << ": " << status.ToString();
    EXPECT_NE(status.message().find(path), std::string::npos) << what << ": " << status.message();
  }
}

TEST_F(KeysTest, AuthorisedClientsFile) {
  const KeyPair robot = *GenerateKeyPair("robot");
  const KeyPair ops = *GenerateKeyPair("ops");
  const std::string text = "clients:\n  - name: robot\n    public_key: \"" + robot.public_key +
                           "\"\n  - name: ops\n    public_key: \"" + ops.public_key +
                           "\"\n    admin: true\n";
  auto keys = AuthorisedKeys::Load(Write("clients.yaml", text));
  ASSERT_TRUE(keys.ok()) << keys.status().ToString();
  ASSERT_EQ((*keys)->size(), 2u);
  ASSERT_NE((*keys)->FindName("robot"), nullptr);
  EXPECT_FALSE((*keys)->FindName("robot")->admin);
  EXPECT_TRUE((*keys)->FindName("ops")->admin);
  EXPECT_EQ((*keys)->FindName("nobody"), nullptr);
  EXPECT_EQ((*keys)->FindBinary(std::string(32, 'x')), nullptr);

  const auto empty = AuthorisedKeys::Parse("clients: []\n", "empty");
  ASSERT_TRUE(empty.ok());
  EXPECT_EQ((*empty)->size(), 0u);  // a server that admits nobody is a valid choice
}

TEST_F(KeysTest, MalformedClientsFilesAreRefusedWithTheEntry) {
  const std::string k = GenerateKeyPair("x")->public_key;
  const std::string k2 = GenerateKeyPair("y")->public_key;
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"not YAML", "clients: ["},
      {"no list", "robots: []\n"},
      {"unknown top field", "clients: []\nextra: 1\n"},
      {"no name", "clients:\n  - public_key: \"" + k + "\"\n"},
      {"bad key", "clients:\n  - name: a\n    public_key: \"nope\"\n"},
      {"unknown field", "clients:\n  - name: a\n    public_key: \"" + k + "\"\n    role: x\n"},
      {"admin not bool",
       "clients:\n  - name: a\n    public_key: \"" + k + "\"\n    admin: maybe\n"},
      {"name twice", "clients:\n  - name: a\n    public_key: \"" + k +
                         "\"\n  - name: a\n    public_key: \"" + k2 + "\"\n"},
      {"key twice", "clients:\n  - name: a\n    public_key: \"" + k +
                        "\"\n  - name: b\n    public_key: \"" + k + "\"\n"},
  };
  for (const auto& [what, text] : bad) {
    const auto keys = AuthorisedKeys::Parse(text, "clients.yaml");
    ASSERT_FALSE(keys.ok()) << what;
    EXPECT_EQ(keys.status().code(), StatusCode::kInvalidArgument) << what;
    EXPECT_NE(keys.status().message().find("clients.yaml"), std::string::npos)
        << what << ": " << keys.status().message();
  }
  EXPECT_EQ(AuthorisedKeys::Load((dir_ / "none.yaml").string()).status().code(),
            StatusCode::kNotFound);
}

}  // namespace
}  // namespace sceneloc

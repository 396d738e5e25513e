#include "common/keys/keys.h"

#include <sys/stat.h>
#include <yaml-cpp/yaml.h>
#include <zmq.h>

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

bool IsKeyName(const std::string& name) {
  if (name.empty() || name.size() > 64 || name[0] == '.') return false;
  for (const char c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.') {
      return false;
    }
  }
  return true;
}

// The 32 bytes of a Z85 key, or empty when it is not one.
std::string DecodeZ85(const std::string& z85) {
  if (z85.size() != kZ85KeyLength) return {};
  std::string binary(32, '\0');
  if (zmq_z85_decode(reinterpret_cast<uint8_t*>(binary.data()), z85.c_str()) == nullptr) return {};
  return binary;
}

StatusOr<std::string> ReadText(const std::string& path) {
  std::error_code error;
  if (!fs::exists(path, error)) return NotFound(path + ": no such file");
  std::ifstream in(path);
  if (!in) return IoError(path + ": cannot be read");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

StatusOr<YAML::Node> ReadYaml(const std::string& path) {
  SCENELOC_ASSIGN_OR_RETURN(const std::string text, ReadText(path));
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    return InvalidArgument(path + ": not YAML: " + e.what());
  }
}

// The string field `key` of `node`, or "" when absent; an error when it is not a string.
StatusOr<std::string> StringField(const YAML::Node& node, const char* key,
                                  const std::string& where) {
  const YAML::Node value = node[key];
  if (!value) return std::string();
  if (!value.IsScalar()) return InvalidArgument(where + ": '" + key + "' must be a string");
  return value.as<std::string>();
}

Status CheckKey(const std::string& z85, const char* what, const std::string& where) {
  if (!IsZ85Key(z85)) {
    return InvalidArgument(where + ": " + what + " must be 40 Z85 characters (got " +
                           std::to_string(z85.size()) + " characters" +
                           (z85.size() == kZ85KeyLength ? " that do not decode" : "") + ")");
  }
  return Status::Ok();
}

Status WriteText(const fs::path& path, const std::string& text, mode_t mode, bool overwrite) {
  std::error_code error;
  if (!overwrite && fs::exists(path, error)) {
    return FailedPrecondition(path.string() + " exists; not overwritten (--force replaces it)");
  }
  const std::string tmp = path.string() + ".tmp";
  FILE* f = std::fopen(tmp.c_str(), "w");
  if (f == nullptr) return IoError("cannot write " + tmp);
  ::chmod(tmp.c_str(), mode);  // before any secret is written
  const bool written = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !written) {
    fs::remove(tmp, error);
    return IoError("cannot write " + tmp);
  }
  fs::rename(tmp, path, error);
  if (error)
    return IoError("cannot rename " + tmp + " to " + path.string() + ": " + error.message());
  return Status::Ok();
}

}  // namespace

bool CurveAvailable() { return zmq_has("curve") != 0; }

bool IsZ85Key(const std::string& z85) { return !DecodeZ85(z85).empty(); }

StatusOr<KeyPair> GenerateKeyPair(const std::string& name) {
  if (!IsKeyName(name)) {
    return InvalidArgument(
        "key name '" + name +
        "' must be 1..64 letters, digits, '.', '_' or '-', not starting with '.'");
  }
  if (!CurveAvailable()) return Unimplemented("this libzmq was built without CURVE");
  char public_key[kZ85KeyLength + 1];
  char secret_key[kZ85KeyLength + 1];
  if (zmq_curve_keypair(public_key, secret_key) != 0) {
    return Internal(std::string("zmq_curve_keypair failed: ") + zmq_strerror(zmq_errno()));
  }
  return KeyPair{name, public_key, secret_key};
}

Status WriteKeyPair(const KeyPair& pair, const std::string& dir, bool overwrite) {
  if (!IsKeyName(pair.name)) return InvalidArgument("key name '" + pair.name + "' is not valid");
  std::error_code error;
  fs::create_directories(dir, error);
  if (error) return IoError("cannot create " + dir + ": " + error.message());
  const std::string pub = "name: " + pair.name + "\npublic_key: \"" + pair.public_key + "\"\n";
  SCENELOC_RETURN_IF_ERROR(WriteText(fs::path(dir) / (pair.name + ".key"),
                                     "# sceneloc key pair: keep this file secret\n" + pub +
                                         "secret_key: \"" + pair.secret_key + "\"\n",
                                     0600, overwrite));
  return WriteText(fs::path(dir) / (pair.name + ".pub"),
                   "# sceneloc public key: give it to the other side\n" + pub, 0644, overwrite);
}

StatusOr<KeyPair> ReadKeyFile(const std::string& path, bool need_secret) {
  SCENELOC_ASSIGN_OR_RETURN(const YAML::Node root, ReadYaml(path));
  if (!root.IsMap()) return InvalidArgument(path + ": not a sceneloc key file");
  KeyPair pair;
  SCENELOC_ASSIGN_OR_RETURN(pair.name, StringField(root, "name", path));
  SCENELOC_ASSIGN_OR_RETURN(pair.public_key, StringField(root, "public_key", path));
  SCENELOC_ASSIGN_OR_RETURN(pair.secret_key, StringField(root, "secret_key", path));
  SCENELOC_RETURN_IF_ERROR(CheckKey(pair.public_key, "public_key", path));
  if (pair.secret_key.empty()) {
    if (need_secret) {
      return InvalidArgument(path +
                             ": holds no secret_key (a .pub file?); a key pair (.key) is needed");
    }
    return pair;
  }
  SCENELOC_RETURN_IF_ERROR(CheckKey(pair.secret_key, "secret_key", path));
  char derived[kZ85KeyLength + 1];
  if (zmq_curve_public(derived, pair.secret_key.c_str()) != 0 || pair.public_key != derived) {
    return InvalidArgument(path + ": public_key does not belong to secret_key");
  }
  return pair;
}

StatusOr<std::shared_ptr<const AuthorisedKeys>> AuthorisedKeys::Load(const std::string& path) {
  SCENELOC_ASSIGN_OR_RETURN(const std::string text, ReadText(path));
  return Parse(text, path);
}

StatusOr<std::shared_ptr<const AuthorisedKeys>> AuthorisedKeys::Parse(const std::string& yaml,
                                                                      const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    return InvalidArgument(source + ": not YAML: " + e.what());
  }
  if (!root.IsMap() || !root["clients"] || !root["clients"].IsSequence()) {
    return InvalidArgument(source + ": needs a 'clients:' list of {name, public_key, admin}");
  }
  for (const auto& field : root) {
    if (field.first.as<std::string>() != "clients") {
      return InvalidArgument(source + ": unknown field '" + field.first.as<std::string>() + "'");
    }
  }
  auto keys = std::make_shared<AuthorisedKeys>();
  keys->source_ = source;
  size_t index = 0;
  for (const YAML::Node& node : root["clients"]) {
    const std::string where = source + ": clients[" + std::to_string(index++) + "]";
    if (!node.IsMap()) return InvalidArgument(where + ": must be {name, public_key, admin}");
    for (const auto& field : node) {
      const std::string key = field.first.as<std::string>();
      if (key != "name" && key != "public_key" && key != "admin") {
        return InvalidArgument(where + ": unknown field '" + key + "'");
      }
    }
    Entry entry;
    SCENELOC_ASSIGN_OR_RETURN(entry.name, StringField(node, "name", where));
    SCENELOC_ASSIGN_OR_RETURN(entry.public_key, StringField(node, "public_key", where));
    if (!IsKeyName(entry.name)) {
      return InvalidArgument(where + ": name '" + entry.name +
                             "' must be 1..64 letters, digits, '.', '_' or '-'");
    }
    SCENELOC_RETURN_IF_ERROR(CheckKey(entry.public_key, "public_key", where));
    if (node["admin"]) {
      try {
        entry.admin = node["admin"].as<bool>();
      } catch (const YAML::Exception&) {
        return InvalidArgument(where + ": admin must be true or false");
      }
    }
    const std::string binary = DecodeZ85(entry.public_key);
    if (keys->by_name_.count(entry.name) != 0) {
      return InvalidArgument(where + ": name '" + entry.name + "' is listed twice");
    }
    if (keys->by_binary_key_.count(binary) != 0) {
      return InvalidArgument(where + ": the key of '" + entry.name + "' is also listed as '" +
                             keys->entries_[keys->by_binary_key_[binary]].name + "'");
    }
    keys->by_name_[entry.name] = keys->entries_.size();
    keys->by_binary_key_[binary] = keys->entries_.size();
    keys->entries_.push_back(std::move(entry));
  }
  return std::shared_ptr<const AuthorisedKeys>(std::move(keys));
}

const AuthorisedKeys::Entry* AuthorisedKeys::FindBinary(const std::string& key32) const {
  const auto it = by_binary_key_.find(key32);
  return it == by_binary_key_.end() ? nullptr : &entries_[it->second];
}

const AuthorisedKeys::Entry* AuthorisedKeys::FindName(const std::string& name) const {
  const auto it = by_name_.find(name);
  return it == by_name_.end() ? nullptr : &entries_[it->second];
}

}  // namespace sceneloc

// tls: schema checks, and reading the PEM files with OpenSSL so a bad file stops the gateway
// at configuration time with the key and the file named (decision 023).
#include "server/config/tls_config.h"

#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "server/config/section.h"

namespace drivegw::config {

const TlsClientPrincipal* FindClientPrincipal(const TlsConfig& tls, std::string_view common_name) {
  for (const TlsClientPrincipal& p : tls.client_principals) {
    if (p.common_name == common_name) return &p;
  }
  return nullptr;
}

namespace internal {
namespace {

// X.520 ub-common-name: a subject CN has at most 64 characters (RFC 5280 Appendix A.1).
constexpr size_t kMaxCommonName = 64;
constexpr size_t kMaxPrincipal = 128;

struct BioFree {
  void operator()(BIO* b) const { BIO_free(b); }
};
struct X509Free {
  void operator()(X509* x) const { X509_free(x); }
};
struct PkeyFree {
  void operator()(EVP_PKEY* k) const { EVP_PKEY_free(k); }
};
using BioPtr = std::unique_ptr<BIO, BioFree>;
using X509Ptr = std::unique_ptr<X509, X509Free>;
using PkeyPtr = std::unique_ptr<EVP_PKEY, PkeyFree>;

// Never prompts on a terminal for a passphrase: an encrypted key simply fails to load.
int NoPassphrase(char* /*buf*/, int /*size*/, int /*rwflag*/, void* /*u*/) { return 0; }

BioPtr MemBio(const std::string& text) {
  return BioPtr(BIO_new_mem_buf(text.data(), static_cast<int>(text.size())));
}

// Every certificate of a PEM text, in file order; OpenSSL's error queue is left empty (the
// end of the text is reported as an error by PEM_read_bio_X509).
std::vector<X509Ptr> ReadCertificates(const std::string& pem) {
  std::vector<X509Ptr> certs;
  BioPtr bio = MemBio(pem);
  while (bio) {
    X509Ptr cert(PEM_read_bio_X509(bio.get(), nullptr, NoPassphrase, nullptr));
    if (!cert) break;
    certs.push_back(std::move(cert));
  }
  ERR_clear_error();
  return certs;
}

PkeyPtr ReadPrivateKey(const std::string& pem) {
  BioPtr bio = MemBio(pem);
  PkeyPtr key(bio ? PEM_read_bio_PrivateKey(bio.get(), nullptr, NoPassphrase, nullptr) : nullptr);
  ERR_clear_error();
  return key;
}

// The node under `key` for the line number of an error, or the section's own node.
YAML::Node NodeFor(const Section& s, std::string_view key) {
  auto n = s.Get(key);
  return n ? *n : YAML::Node();
}

// Reads the file named under `key`; an error names the key and the file.
std::optional<std::string> ReadPemFile(const Section& s, std::string_view key,
                                       const std::string& path) {
  const YAML::Node at = NodeFor(s, key);
  auto fail = [&](std::string_view what) {
    s.errors().Add(s.Child(key), absl::StrCat("file '", path, "' ", std::string(what)), at);
    return std::nullopt;
  };
  std::error_code ec;
  const auto st = std::filesystem::status(path, ec);
  if (st.type() == std::filesystem::file_type::not_found) return fail("not found");
  if (ec) return fail(absl::StrCat("cannot be read (", ec.message(), ")"));
  if (std::filesystem::is_directory(st)) return fail("is a directory");
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec && size > kMaxPemFileBytes) {
    return fail(absl::StrCat("is ", size, " bytes, more than ", kMaxPemFileBytes));
  }
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return fail(
        absl::StrCat("cannot be read (", errno != 0 ? std::strerror(errno) : "open failed", ")"));
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return fail("cannot be read (read failed)");
  return text.str();
}

// "viewer, operator, engineer, admin".
std::string RoleList() {
  std::string list;
  for (std::string_view role : kTlsRoles) {
    if (!list.empty()) list += ", ";
    list += role;
  }
  return list;
}

void ParsePrincipals(const Section& s, TlsConfig& tls) {
  const auto node = s.Get("client_principals");
  if (!node || node->IsNull()) return;
  const std::string path = s.Child("client_principals");
  if (!node->IsSequence()) {
    s.errors().Add(path, absl::StrCat("expected a sequence, got ", KindName(*node)), *node);
    return;
  }
  std::map<std::string, size_t> seen;  // common_name -> first index
  for (size_t i = 0; i < node->size(); ++i) {
    const YAML::Node entry = (*node)[i];
    const Section e(entry, absl::StrCat(path, "[", i, "]"), {"common_name", "principal", "role"},
                    s.errors());
    if (!entry.IsMap()) {
      if (entry.IsNull()) s.errors().Add(e.Label(), "expected a mapping, got null", entry);
      continue;
    }
    TlsClientPrincipal p;
    if (e.String("common_name", p.common_name, /*required=*/true)) {
      if (p.common_name.empty() || p.common_name.size() > kMaxCommonName) {
        e.errors().Add(
            e.Child("common_name"),
            absl::StrCat("must be 1..", kMaxCommonName, " characters (X.520 ub-common-name)"),
            NodeFor(e, "common_name"));
      } else if (auto [it, fresh] = seen.emplace(p.common_name, i); !fresh) {
        e.errors().Add(
            e.Child("common_name"),
            absl::StrCat("'", p.common_name, "' already mapped by ", path, "[", it->second, "]"),
            NodeFor(e, "common_name"));
      }
    }
    if (e.String("principal", p.principal)) {
      const bool control = std::any_of(p.principal.begin(), p.principal.end(), [](char c) {
        return static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
      });
      if (p.principal.empty() || p.principal.size() > kMaxPrincipal || control) {
        e.errors().Add(
            e.Child("principal"),
            absl::StrCat("must be 1..", kMaxPrincipal, " characters without control characters"),
            NodeFor(e, "principal"));
      }
    } else {
      p.principal = p.common_name;
    }
    if (e.String("role", p.role, /*required=*/true) &&
        std::find(std::begin(kTlsRoles), std::end(kTlsRoles), p.role) == std::end(kTlsRoles)) {
      e.errors().Add(
          e.Child("role"),
          absl::StrCat("'", p.role, "' is not a role (", RoleList(), ")"),
          NodeFor(e, "role"));
    }
    tls.client_principals.push_back(std::move(p));
  }
}

// A non-empty path under `key` (required or optional); false when absent or bad.
bool PathKey(const Section& s, std::string_view key, std::string& out, bool required) {
  if (!s.String(key, out, required)) return false;
  if (out.empty()) {
    s.errors().Add(s.Child(key), "must not be empty", NodeFor(s, key));
    return false;
  }
  return true;
}

// Reads and checks the files: the certificate (chain) and the key that must match its first
// certificate, and the client CA bundle.
void LoadFiles(const Section& s, bool has_cert, bool has_key, bool has_ca, TlsConfig& tls) {
  X509Ptr leaf;
  if (has_cert) {
    if (auto text = ReadPemFile(s, "cert", tls.cert_path)) {
      std::vector<X509Ptr> certs = ReadCertificates(*text);
      if (certs.empty()) {
        s.errors().Add(s.Child("cert"),
                       absl::StrCat("file '", tls.cert_path, "' holds no PEM certificate"),
                       NodeFor(s, "cert"));
      } else {
        leaf = std::move(certs.front());
        tls.cert_pem = *std::move(text);
      }
    }
  }
  if (has_key) {
    if (auto text = ReadPemFile(s, "key", tls.key_path)) {
      PkeyPtr key = ReadPrivateKey(*text);
      if (!key) {
        const bool encrypted = text->find("ENCRYPTED") != std::string::npos;
        s.errors().Add(s.Child("key"),
                       absl::StrCat("file '", tls.key_path, "' ",
                                    encrypted ? "holds an encrypted private key (drivegw reads "
                                                "unencrypted keys; protect the file instead)"
                                              : "holds no PEM private key"),
                       NodeFor(s, "key"));
      } else if (leaf && X509_check_private_key(leaf.get(), key.get()) != 1) {
        ERR_clear_error();
        s.errors().Add(
            s.Child("key"),
            absl::StrCat("the key in '", tls.key_path,
                         "' does not match the certificate in tls.cert '", tls.cert_path, "'"),
            NodeFor(s, "key"));
      } else {
        tls.key_pem = *std::move(text);
      }
    }
  }
  if (has_ca) {
    if (auto text = ReadPemFile(s, "client_ca", tls.client_ca_path)) {
      if (ReadCertificates(*text).empty()) {
        s.errors().Add(s.Child("client_ca"),
                       absl::StrCat("file '", tls.client_ca_path, "' holds no PEM certificate"),
                       NodeFor(s, "client_ca"));
      } else {
        tls.client_ca_pem = *std::move(text);
      }
    }
  }
}

}  // namespace

void ParseTls(const Section& root, std::optional<TlsConfig>& out) {
  const auto node = root.Get("tls");
  if (!node) return;
  const Section s(*node, "tls",
                  {"cert", "key", "client_ca", "require_client_cert", "client_principals"},
                  root.errors());
  if (!node->IsNull() && !node->IsMap()) return;  // Section reported it
  TlsConfig tls;
  const bool has_cert = PathKey(s, "cert", tls.cert_path, /*required=*/true);
  const bool has_key = PathKey(s, "key", tls.key_path, /*required=*/true);
  const bool has_ca = PathKey(s, "client_ca", tls.client_ca_path, /*required=*/false);
  s.Bool("require_client_cert", tls.require_client_cert);
  if (tls.require_client_cert && !s.Has("client_ca")) {
    s.errors().Add(s.Child("require_client_cert"),
                   "true needs tls.client_ca (the CA that signs the client certificates)",
                   NodeFor(s, "require_client_cert"));
  }
  ParsePrincipals(s, tls);
  if (!tls.client_principals.empty() && !s.Has("client_ca")) {
    s.errors().Add(s.Child("client_principals"),
                   "needs tls.client_ca: only a verified client certificate maps to a principal",
                   NodeFor(s, "client_principals"));
  }
  LoadFiles(s, has_cert, has_key, has_ca, tls);
  out = std::move(tls);
}

}  // namespace internal
}  // namespace drivegw::config

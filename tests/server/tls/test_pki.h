// Test certificates made at test time with the openssl CLI in a temporary directory: a CA, a
// server certificate for 127.0.0.1/localhost, client certificates, and a second CA nobody
// trusts. Also runs curl, the HTTPS client of the tests (both in scripts/install-deps.sh).
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace drivegw::testing {

struct CommandResult {
  int exit_code = -1;  // -1: not run or killed by a signal
  std::string output;  // stdout and stderr
};

// Runs `command` with /bin/sh; stdin from /dev/null.
inline CommandResult RunCommand(const std::string& command) {
  CommandResult r;
  FILE* pipe = ::popen((command + " </dev/null 2>&1").c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buf{};
  size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) r.output.append(buf.data(), n);
  const int status = ::pclose(pipe);
  if (status != -1 && WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  return r;
}

inline std::string Quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

inline void WriteFile(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

inline std::string ReadFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A PKI in a fresh directory under /tmp, removed by the destructor. Keys are P-256 (fast to make).
class TestPki {
 public:
  TestPki() {
    char tmpl[] = "/tmp/drivegw-tls-XXXXXX";
    if (::mkdtemp(tmpl) != nullptr) dir_ = tmpl;
  }
  ~TestPki() {
    std::error_code ec;
    if (!dir_.empty()) std::filesystem::remove_all(dir_, ec);
  }
  TestPki(const TestPki&) = delete;
  TestPki& operator=(const TestPki&) = delete;

  const std::filesystem::path& dir() const { return dir_; }
  std::string Path(const std::string& file) const { return (dir_ / file).string(); }

  // <name>.pem and <name>.key: a self-signed CA with subject CN `cn`.
  ::testing::AssertionResult MakeCa(const std::string& name, const std::string& cn) {
    WriteFile(dir_ / (name + ".cnf"),
              "[req]\ndistinguished_name = dn\nprompt = no\nx509_extensions = v3_ca\n"
              "[dn]\nCN = " +
                  cn +
                  "\n"
                  "[v3_ca]\nbasicConstraints = critical,CA:TRUE\n"
                  "keyUsage = critical,keyCertSign,cRLSign\nsubjectKeyIdentifier = hash\n");
    return Openssl("req -x509 -config " + Quote(Path(name + ".cnf")) + " " + NewKey(name) +
                   " -out " + Quote(Path(name + ".pem")) + " -days 2");
  }

  // <name>.pem and <name>.key signed by CA `ca`: a server certificate (SAN IP 127.0.0.1 and
  // DNS localhost, serverAuth) or a client certificate (clientAuth), subject CN `cn`.
  ::testing::AssertionResult MakeLeaf(const std::string& ca, const std::string& name,
                                      const std::string& cn, bool server) {
    WriteFile(dir_ / (name + ".ext"),
              std::string("basicConstraints = CA:FALSE\nkeyUsage = critical,digitalSignature\n") +
                  (server ? "extendedKeyUsage = serverAuth\n"
                            "subjectAltName = IP:127.0.0.1,DNS:localhost\n"
                          : "extendedKeyUsage = clientAuth\n"));
    auto csr = Openssl("req -new " + NewKey(name) + " -subj " + Quote("/CN=" + cn) + " -out " +
                       Quote(Path(name + ".csr")));
    if (!csr) return csr;
    return Openssl("x509 -req -in " + Quote(Path(name + ".csr")) + " -CA " +
                   Quote(Path(ca + ".pem")) + " -CAkey " + Quote(Path(ca + ".key")) +
                   " -CAcreateserial -CAserial " + Quote(Path(ca + ".srl")) + " -days 2 -extfile " +
                   Quote(Path(name + ".ext")) + " -out " + Quote(Path(name + ".pem")));
  }

  // Runs `openssl <args>`; failure carries the command's output.
  static ::testing::AssertionResult Openssl(const std::string& args) {
    const CommandResult r = RunCommand("openssl " + args);
    if (r.exit_code == 0) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure()
           << "openssl " << args << " -> exit " << r.exit_code << ":\n"
           << r.output;
  }

 private:
  std::string NewKey(const std::string& name) const {
    return "-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -keyout " +
           Quote(Path(name + ".key"));
  }

  std::filesystem::path dir_;
};

// curl against https://127.0.0.1:<port><target>; `options` adds --cacert, --cert, ... The
// output is the body followed by "\nHTTP <code>"; exit_code is curl's (0 ok, 35 handshake
// failed, 56 receive failed, 60 peer certificate not trusted).
inline CommandResult Curl(int port, const std::string& target, const std::string& options) {
  return RunCommand("curl -sS --noproxy '*' --max-time 20 -w '\\nHTTP %{http_code}' " + options +
                    " " + Quote("https://127.0.0.1:" + std::to_string(port) + target));
}

}  // namespace drivegw::testing

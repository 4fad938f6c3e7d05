// The tls: section: schema, the client principal mapping, and the file checks (missing,
// directory, not PEM, encrypted key, key not matching the certificate) on files made by openssl.
#include "server/config/tls_config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "server/config/config.h"
#include "tests/server/tls/test_pki.h"

namespace drivegw::config {
namespace {

using ::testing::HasSubstr;
using testing::Quote;
using testing::TestPki;
using testing::WriteFile;

class TlsConfigTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    pki_ = new TestPki();
    ASSERT_TRUE(pki_->MakeCa("ca", "drivegw test CA"));
    ASSERT_TRUE(pki_->MakeLeaf("ca", "server", "localhost", /*server=*/true));
    ASSERT_TRUE(pki_->MakeLeaf("ca", "client", "line-3", /*server=*/false));
    WriteFile(pki_->dir() / "garbage.txt", "not a certificate\n");
    ASSERT_TRUE(TestPki::Openssl("pkey -in " + Quote(P("client.key")) +
                                 " -aes256 -passout pass:secret -out " + Quote(P("enc.key"))));
  }
  static void TearDownTestSuite() {
    delete pki_;
    pki_ = nullptr;
  }
  static std::string P(const std::string& file) { return pki_->Path(file); }

  // `tls:` with cert and key of the server plus `extra` lines (two-space indented).
  static std::string Yaml(const std::string& extra, const std::string& cert = P("server.pem"),
                          const std::string& key = P("server.key")) {
    return "tls:\n  cert: \"" + cert + "\"\n  key: \"" + key + "\"\n" + extra;
  }
  static std::string Error(const std::string& yaml) {
    auto cfg = ParseConfig(yaml);
    EXPECT_FALSE(cfg.ok()) << yaml;
    return cfg.ok() ? "" : std::string(cfg.status().message());
  }

  static TestPki* pki_;
};
TestPki* TlsConfigTest::pki_ = nullptr;

TEST_F(TlsConfigTest, ParseConfig_NoTlsKey_PlainTransport) {
  auto cfg = ParseConfig("data_dir: ./d\n");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_FALSE(cfg->tls.has_value());
}

TEST_F(TlsConfigTest, ParseConfig_CertAndKey_LoadsPem) {
  auto cfg = ParseConfig(Yaml(""));
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  ASSERT_TRUE(cfg->tls.has_value());
  EXPECT_EQ(cfg->tls->cert_path, P("server.pem"));
  EXPECT_THAT(cfg->tls->cert_pem, HasSubstr("-----BEGIN CERTIFICATE-----"));
  EXPECT_THAT(cfg->tls->key_pem, HasSubstr("PRIVATE KEY-----"));
  EXPECT_TRUE(cfg->tls->client_ca_pem.empty());
  EXPECT_FALSE(cfg->tls->require_client_cert);
  EXPECT_TRUE(cfg->tls->client_principals.empty());
}

TEST_F(TlsConfigTest, ParseConfig_ClientCaAndPrincipals_Mapped) {
  auto cfg = ParseConfig(Yaml("  client_ca: \"" + P("ca.pem") +
                              "\"\n  require_client_cert: true\n  client_principals:\n"
                              "    - {common_name: line-3, principal: mes-line-3, role: operator}\n"
                              "    - {common_name: eng-laptop, role: engineer}\n"));
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  const TlsConfig& tls = *cfg->tls;
  EXPECT_THAT(tls.client_ca_pem, HasSubstr("-----BEGIN CERTIFICATE-----"));
  EXPECT_TRUE(tls.require_client_cert);
  const TlsClientPrincipal* p = FindClientPrincipal(tls, "line-3");
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(p->principal, "mes-line-3");
  EXPECT_EQ(p->role, "operator");
  p = FindClientPrincipal(tls, "eng-laptop");
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(p->principal, "eng-laptop");                   // defaults to the CN
  EXPECT_EQ(FindClientPrincipal(tls, "LINE-3"), nullptr);  // exact match only
  EXPECT_EQ(FindClientPrincipal(tls, "unknown"), nullptr);
}

TEST_F(TlsConfigTest, ParseConfig_MissingFile_NamesKeyAndFile) {
  const std::string missing = P("nope.pem");
  EXPECT_THAT(Error(Yaml("", missing)),
              HasSubstr("tls.cert: file '" + missing + "' not found (line 2"));
  EXPECT_THAT(Error(Yaml("  client_ca: \"" + missing + "\"\n")),
              HasSubstr("tls.client_ca: file '" + missing + "' not found"));
}

TEST_F(TlsConfigTest, ParseConfig_Directory_Refused) {
  EXPECT_THAT(Error(Yaml("", P("server.pem"), pki_->dir().string())),
              HasSubstr("tls.key: file '" + pki_->dir().string() + "' is a directory"));
}

TEST_F(TlsConfigTest, ParseConfig_NotPem_NamesKeyAndFile) {
  const std::string garbage = P("garbage.txt");
  EXPECT_THAT(Error(Yaml("", garbage)),
              HasSubstr("tls.cert: file '" + garbage + "' holds no PEM certificate"));
  EXPECT_THAT(Error(Yaml("", P("server.pem"), garbage)),
              HasSubstr("tls.key: file '" + garbage + "' holds no PEM private key"));
  EXPECT_THAT(Error(Yaml("  client_ca: \"" + garbage + "\"\n")),
              HasSubstr("tls.client_ca: file '" + garbage + "' holds no PEM certificate"));
  // A certificate is not a key, and a key is not a certificate.
  EXPECT_THAT(Error(Yaml("", P("server.pem"), P("server.pem"))),
              HasSubstr("tls.key: file '" + P("server.pem") + "' holds no PEM private key"));
}

TEST_F(TlsConfigTest, ParseConfig_KeyOfAnotherCertificate_Refused) {
  EXPECT_THAT(Error(Yaml("", P("server.pem"), P("client.key"))),
              HasSubstr("tls.key: the key in '" + P("client.key") +
                        "' does not match the certificate in tls.cert '" + P("server.pem") + "'"));
}

TEST_F(TlsConfigTest, ParseConfig_EncryptedKey_RefusedWithoutPrompt) {
  EXPECT_THAT(Error(Yaml("", P("client.pem"), P("enc.key"))),
              HasSubstr("tls.key: file '" + P("enc.key") + "' holds an encrypted private key"));
}

TEST_F(TlsConfigTest, ParseConfig_Shape_EveryProblemNamed) {
  EXPECT_THAT(Error("tls:\n  cert: \"" + P("server.pem") + "\"\n"), HasSubstr("tls.key: required"));
  EXPECT_THAT(Error("tls:\n"), HasSubstr("tls.cert: required"));
  EXPECT_THAT(Error("tls: on\n"), HasSubstr("tls: expected a mapping"));
  EXPECT_THAT(Error(Yaml("  clientca: x\n")),
              HasSubstr("tls.clientca: unknown key (did you mean 'client_ca'?)"));
  EXPECT_THAT(Error(Yaml("", "")), HasSubstr("tls.cert: must not be empty"));
  EXPECT_THAT(Error(Yaml("  require_client_cert: yes-please\n")),
              HasSubstr("tls.require_client_cert: 'yes-please' is not true or false"));
}

TEST_F(TlsConfigTest, ParseConfig_ClientRulesWithoutClientCa_Refused) {
  EXPECT_THAT(Error(Yaml("  require_client_cert: true\n")),
              HasSubstr("tls.require_client_cert: true needs tls.client_ca"));
  EXPECT_THAT(Error(Yaml("  client_principals:\n    - {common_name: a, role: viewer}\n")),
              HasSubstr("tls.client_principals: needs tls.client_ca"));
}

TEST_F(TlsConfigTest, ParseConfig_BadPrincipals_NamedByIndex) {
  const std::string ca = "  client_ca: \"" + P("ca.pem") + "\"\n  client_principals:\n";
  EXPECT_THAT(Error(Yaml(ca + "    - {common_name: a, role: root}\n")),
              HasSubstr("tls.client_principals[0].role: 'root' is not a role (viewer, operator, "
                        "engineer, admin)"));
  EXPECT_THAT(Error(Yaml(ca + "    - {common_name: a, role: viewer}\n"
                              "    - {common_name: a, role: admin}\n")),
              HasSubstr("tls.client_principals[1].common_name: 'a' already mapped by "
                        "tls.client_principals[0]"));
  EXPECT_THAT(Error(Yaml(ca + "    - {common_name: a}\n")),
              HasSubstr("tls.client_principals[0].role: required"));
  EXPECT_THAT(Error(Yaml(ca + "    - {role: viewer}\n")),
              HasSubstr("tls.client_principals[0].common_name: required"));
  EXPECT_THAT(Error(Yaml(ca + "    - {common_name: a, role: viewer, group: x}\n")),
              HasSubstr("tls.client_principals[0].group: unknown key"));
  EXPECT_THAT(
      Error(Yaml(ca + "    - {common_name: \"" + std::string(65, 'c') + "\", role: viewer}\n")),
      HasSubstr("tls.client_principals[0].common_name: must be 1..64 characters"));
  EXPECT_THAT(Error(Yaml("  client_ca: \"" + P("ca.pem") + "\"\n  client_principals: x\n")),
              HasSubstr("tls.client_principals: expected a sequence"));
}

}  // namespace
}  // namespace drivegw::config

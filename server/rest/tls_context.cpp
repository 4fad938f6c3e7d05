// OpenSSL context and peer certificate helpers of the HTTPS server (no Beast in this TU).
#include "server/rest/tls_context.h"

#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/x509.h>

#include <boost/asio/ssl/context.hpp>
#include <memory>

#include "absl/strings/str_cat.h"

namespace drivegw::rest {
namespace {

namespace ssl = boost::asio::ssl;

// Session ID context: OpenSSL refuses to resume a session of a context that verifies client
// certificates without one (SSL_CTX_set_session_id_context(3)).
constexpr unsigned char kSessionIdContext[] = "drivegw-rest";

absl::Status Refused(std::string_view field, const boost::system::error_code& ec) {
  return absl::InvalidArgumentError(
      absl::StrCat("rest.tls.", std::string(field), ": ", ec.message()));
}

// Lists the client CA subjects in the CertificateRequest so a client holding several
// certificates picks the right one (RFC 5246 §7.4.4 certificate_authorities).
void AdvertiseClientCas(const std::string& pem, SSL_CTX* ctx) {
  std::unique_ptr<BIO, decltype(&BIO_free)> bio(
      BIO_new_mem_buf(pem.data(), static_cast<int>(pem.size())), &BIO_free);
  while (bio) {
    std::unique_ptr<X509, decltype(&X509_free)> cert(
        PEM_read_bio_X509(bio.get(), nullptr, nullptr, nullptr), &X509_free);
    if (!cert) break;
    SSL_CTX_add_client_CA(ctx, cert.get());  // copies the subject name
  }
  ERR_clear_error();
}

}  // namespace

absl::Status ConfigureTlsContext(const RestTls& tls, ssl::context& ctx) {
  boost::system::error_code ec;
  // Issue 7 asks for TLS on HTTP; 1.0 and 1.1 are deprecated (RFC 8996), so 1.2 is the floor.
  ctx.set_options(ssl::context::default_workarounds | ssl::context::no_sslv2 |
                      ssl::context::no_sslv3 | ssl::context::no_tlsv1 | ssl::context::no_tlsv1_1 |
                      ssl::context::no_compression,
                  ec);
  if (ec) return Refused("options", ec);
  if (SSL_CTX_set_min_proto_version(ctx.native_handle(), TLS1_2_VERSION) != 1) {
    ERR_clear_error();
    return absl::InternalError("rest.tls: cannot set TLS 1.2 as the minimum version");
  }
  // Never prompt for a passphrase on a terminal: encrypted keys are refused by the config.
  ctx.set_password_callback(
      [](std::size_t, ssl::context::password_purpose) { return std::string(); }, ec);
  if (ec) return Refused("key", ec);
  ctx.use_certificate_chain(boost::asio::buffer(tls.cert_chain_pem), ec);
  if (ec) return Refused("cert", ec);
  ctx.use_private_key(boost::asio::buffer(tls.key_pem), ssl::context::pem, ec);
  if (ec) return Refused("key", ec);
  if (tls.client_ca_pem.empty()) {
    ctx.set_verify_mode(ssl::verify_none, ec);
    return ec ? Refused("client_ca", ec) : absl::OkStatus();
  }
  ctx.add_certificate_authority(boost::asio::buffer(tls.client_ca_pem), ec);
  if (ec) return Refused("client_ca", ec);
  AdvertiseClientCas(tls.client_ca_pem, ctx.native_handle());
  ctx.set_verify_mode(
      ssl::verify_peer | (tls.require_client_cert ? ssl::verify_fail_if_no_peer_cert : 0), ec);
  if (ec) return Refused("client_ca", ec);
  SSL_CTX_set_session_id_context(ctx.native_handle(), kSessionIdContext,
                                 sizeof kSessionIdContext - 1);
  return absl::OkStatus();
}

std::string VerifiedClientCommonName(SSL* ssl) {
  if (ssl == nullptr) return "";
  std::unique_ptr<X509, decltype(&X509_free)> cert(SSL_get1_peer_certificate(ssl), &X509_free);
  if (!cert || SSL_get_verify_result(ssl) != X509_V_OK) return "";
  X509_NAME* subject = X509_get_subject_name(cert.get());
  const int index = X509_NAME_get_index_by_NID(subject, NID_commonName, -1);
  if (index < 0) return "";
  unsigned char* utf8 = nullptr;
  const int length =
      ASN1_STRING_to_UTF8(&utf8, X509_NAME_ENTRY_get_data(X509_NAME_get_entry(subject, index)));
  if (length < 0) {
    ERR_clear_error();
    return "";
  }
  std::string cn(reinterpret_cast<const char*>(utf8), static_cast<size_t>(length));
  OPENSSL_free(utf8);
  // An embedded NUL would let "admin\0..." pass for another name further on.
  return cn.find('\0') == std::string::npos ? cn : "";
}

}  // namespace drivegw::rest

// Serving the embedded dashboard files: lookup, Content-Type, cache headers (decision 505).
#include "server/rest/static_assets.h"

#include <map>
#include <string>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"

namespace drivegw::rest {
namespace {

constexpr int kNotFound = 5;
constexpr int kUnavailable = 14;
// RFC 9111 §5.2.2.1 max-age plus RFC 8246 immutable: a hashed name never changes content.
constexpr std::string_view kImmutable = "public, max-age=31536000, immutable";
// RFC 9111 §5.2.2.4: revalidate every time, so a new build's index.html is seen at once.
constexpr std::string_view kNoCache = "no-cache";

HttpResponse FileResponse(const WebAsset& file, std::string_view cache_control) {
  HttpResponse r;
  r.content_type = std::string(ContentTypeFor(file.path));
  r.body = std::string(file.data);
  r.headers.emplace_back("Cache-Control", std::string(cache_control));
  r.headers.emplace_back("X-Content-Type-Options", "nosniff");
  return r;
}

}  // namespace

const WebAsset* WebAssetSet::Find(std::string_view path) const {
  for (size_t i = 0; i < count; ++i) {
    if (files[i].path == path) return &files[i];
  }
  return nullptr;
}

std::string_view ContentTypeFor(std::string_view file_name) {
  static const std::map<std::string, std::string_view, std::less<>> kTypes = {
      {".html", "text/html; charset=utf-8"},
      {".htm", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".map", "application/json"},
      {".svg", "image/svg+xml"},
      {".png", "image/png"},
      {".jpg", "image/jpeg"},
      {".jpeg", "image/jpeg"},
      {".gif", "image/gif"},
      {".ico", "image/x-icon"},
      {".webp", "image/webp"},
      {".txt", "text/plain; charset=utf-8"},
      {".wasm", "application/wasm"},
      {".woff", "font/woff"},
      {".woff2", "font/woff2"},
  };
  const size_t slash = file_name.rfind('/');
  const std::string_view base =
      slash == std::string_view::npos ? file_name : file_name.substr(slash + 1);
  const size_t dot = base.rfind('.');
  if (dot == std::string_view::npos) return "application/octet-stream";
  const auto it = kTypes.find(absl::AsciiStrToLower(std::string(base.substr(dot))));
  return it == kTypes.end() ? std::string_view("application/octet-stream") : it->second;
}

bool IsHashedName(std::string_view file_name) {
  // Vite 5 names build output "[name]-[hash].[ext]" with an 8-character base64url hash, which
  // may itself contain '-' (so count from the end, not from the last '-').
  constexpr size_t kHash = 8;
  const size_t slash = file_name.rfind('/');
  std::string_view base = slash == std::string_view::npos ? file_name : file_name.substr(slash + 1);
  const size_t dot = base.find('.');
  if (dot == std::string_view::npos) return false;
  base = base.substr(0, dot);
  if (base.size() < kHash + 2 || base[base.size() - kHash - 1] != '-') return false;
  for (char c : base.substr(base.size() - kHash)) {
    if (!absl::ascii_isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') return false;
  }
  return true;
}

HttpResponse ServeWebAsset(const WebAssetSet& assets, std::string_view path) {
  if (path == "/" || path == "/index.html") {
    if (assets.count == 0) {
      return ErrorResponse(503, kUnavailable,
                           "dashboard not built: run scripts/build-web.sh, then rebuild drivegw");
    }
    if (const WebAsset* index = assets.Find("index.html")) return FileResponse(*index, kNoCache);
  } else if (path.size() > 1 && path.front() == '/') {
    const std::string_view rel = path.substr(1);
    const bool in_assets = rel.rfind("assets/", 0) == 0;
    // Only assets/<file> and the top-level files of web/dist (favicon): nothing deeper.
    if (in_assets || rel.find('/') == std::string_view::npos) {
      if (const WebAsset* file = assets.Find(rel)) {
        return FileResponse(*file, in_assets && IsHashedName(rel) ? kImmutable : kNoCache);
      }
    }
  }
  return ErrorResponse(404, kNotFound,
                       absl::StrCat("no route or file for GET ", std::string(path)));
}

}  // namespace drivegw::rest

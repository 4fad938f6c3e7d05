// The dashboard's files (web/dist, embedded at build time by cmake/embed_web_assets.cmake) and
// how GET / and GET /assets/<file> answer from them (issue 8, decision 505).
#pragma once

#include <cstddef>
#include <string_view>

#include "server/rest/router.h"

namespace drivegw::rest {

struct WebAsset {
  std::string_view path;  // relative to web/dist: "index.html", "assets/index-3f9a1c2b.js"
  std::string_view data;
};

struct WebAssetSet {
  const WebAsset* files;
  size_t count;  // 0: the dashboard was not built (web/ had no package.json)
  const WebAsset* Find(std::string_view path) const;
};

// web/dist as embedded into this binary (generated web_assets_embedded.cpp).
const WebAssetSet& EmbeddedWebAssets();

// Content-Type for a file name by its extension (application/octet-stream if unknown).
std::string_view ContentTypeFor(std::string_view file_name);

// True for Vite's content-hashed names ("index-3f9a1c2b.js": '-' and 8 characters of
// [A-Za-z0-9_-] before the extension): they may be cached for good.
bool IsHashedName(std::string_view file_name);

// GET `path` (percent-decoded, without query) from `assets`: "/" and "/index.html" give
// index.html (Cache-Control: no-cache; 503 "dashboard not built" when the set is empty),
// "/assets/<file>" and other files at the top of web/dist give the file (immutable when hashed,
// else no-cache); anything else 404.
HttpResponse ServeWebAsset(const WebAssetSet& assets, std::string_view path);

}  // namespace drivegw::rest

// `drivegw token create|list|revoke`: API tokens managed directly in the configured SQLite file
// (data_dir/drivegw.db), so the first admin token exists before any API call can be made
// (issue 7 "created and revoked through the API and a CLI subcommand", decision 015).
#pragma once

#include <cstdio>

namespace drivegw::cli {

// `args` are the words after "token" (argv + 2). Writes the new token (create) or the table
// (list) to `out`, everything else to `err`. Exit codes: 0 done, 1 refused or failed (message
// names why), 2 usage or configuration error.
int RunTokenCommand(int argc, const char* const* args, std::FILE* out, std::FILE* err);

// True when argv[1] is "token": main.cpp dispatches to RunTokenCommand.
bool IsTokenCommand(int argc, const char* const* argv);

}  // namespace drivegw::cli

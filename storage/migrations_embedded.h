// Internal seam between the generated migrations_embedded.cpp and migrations.cpp.
#pragma once

namespace drivegw::storage::internal {

struct EmbeddedMigration {
  const char* name;  // "001_initial.sql"
  const char* sql;   // the file's bytes
};

extern const EmbeddedMigration kEmbeddedMigrations[];  // sorted by file name
extern const int kEmbeddedMigrationCount;

}  // namespace drivegw::storage::internal

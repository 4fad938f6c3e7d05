-- 002_parameter_sets: versioned parameter sets and their apply operations (issue 6).
-- Timestamps as in 001: UTC ISO-8601 text with milliseconds, fixed width (24 characters).
-- Values are JSON text [{"parameter":"$14.vmax","id":14,"value":300}, ...] in written order: a
-- version is read and written whole, never queried by parameter (decision 410).

CREATE TABLE parameter_sets (
  name          TEXT    PRIMARY KEY
                CHECK (length(name) BETWEEN 1 AND 128 AND name NOT GLOB '*[^A-Za-z0-9._-]*'),
  family        TEXT    NOT NULL CHECK (family <> ''),
  model         TEXT    NOT NULL DEFAULT '',
  description   TEXT    NOT NULL DEFAULT '',
  target_stored INTEGER NOT NULL CHECK (target_stored IN (0, 1)),
  created_at    TEXT    NOT NULL CHECK (length(created_at) = 24),
  updated_at    TEXT    NOT NULL CHECK (length(updated_at) = 24),
  version       INTEGER NOT NULL CHECK (version >= 1),
  etag          TEXT    NOT NULL CHECK (etag <> '')
);

CREATE INDEX parameter_sets_family_name ON parameter_sets (family, name);

CREATE TABLE parameter_set_versions (
  set_name    TEXT    NOT NULL REFERENCES parameter_sets (name) ON DELETE CASCADE,
  version     INTEGER NOT NULL CHECK (version >= 1),
  author      TEXT    NOT NULL,
  comment     TEXT    NOT NULL,
  created_at  TEXT    NOT NULL CHECK (length(created_at) = 24),
  values_json TEXT    NOT NULL CHECK (json_valid(values_json) AND json_type(values_json) = 'array'),
  PRIMARY KEY (set_name, version)
);

-- A version is history: never changed. It is removed only together with its set (the cascade
-- of DELETE FROM parameter_sets runs after the set row is gone, so the WHEN clause lets it pass).
CREATE TRIGGER parameter_set_versions_no_update BEFORE UPDATE ON parameter_set_versions
BEGIN
  SELECT RAISE(ABORT, 'parameter_set_versions are immutable');
END;

CREATE TRIGGER parameter_set_versions_no_delete BEFORE DELETE ON parameter_set_versions
WHEN EXISTS (SELECT 1 FROM parameter_sets WHERE name = OLD.set_name)
BEGIN
  SELECT RAISE(ABORT, 'parameter_set_versions are removed only with their set');
END;

-- Apply operations keep their own copy of what they did (set name and version, per-drive
-- pre-images as JSON): no foreign key, so deleting the set leaves them. AUTOINCREMENT: an id
-- ("op-<id>") is never handed out twice.
CREATE TABLE apply_operations (
  id          INTEGER PRIMARY KEY AUTOINCREMENT,
  set_name    TEXT    NOT NULL CHECK (set_name <> ''),
  set_version INTEGER NOT NULL CHECK (set_version >= 0),
  dry_run     INTEGER NOT NULL CHECK (dry_run IN (0, 1)),
  state       TEXT    NOT NULL
              CHECK (state IN ('RUNNING', 'SUCCEEDED', 'FAILED', 'FAILED_ROLLBACK')),
  principal   TEXT    NOT NULL,
  created_at  TEXT    NOT NULL CHECK (length(created_at) = 24),
  updated_at  TEXT    NOT NULL CHECK (length(updated_at) = 24),
  drives_json TEXT    NOT NULL CHECK (json_valid(drives_json) AND json_type(drives_json) = 'array')
);

-- Progress updates change state, drives and updated_at only; what was applied, by whom and when
-- it started is fixed, and an operation is never removed.
CREATE TRIGGER apply_operations_fixed_columns
BEFORE UPDATE OF id, set_name, set_version, dry_run, principal, created_at ON apply_operations
WHEN NEW.id IS NOT OLD.id OR NEW.set_name IS NOT OLD.set_name
  OR NEW.set_version IS NOT OLD.set_version OR NEW.dry_run IS NOT OLD.dry_run
  OR NEW.principal IS NOT OLD.principal OR NEW.created_at IS NOT OLD.created_at
BEGIN
  SELECT RAISE(ABORT, 'apply_operations: only state, drives and updated_at change');
END;

CREATE TRIGGER apply_operations_no_delete BEFORE DELETE ON apply_operations
BEGIN
  SELECT RAISE(ABORT, 'apply_operations are never deleted');
END;

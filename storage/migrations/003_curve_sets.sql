-- 003_curve_sets: versioned curve sets (issue 6 "Curve sets", decision 411).
-- Same shape as 002's parameter sets: one row per set pointing at its newest immutable version.
-- Timestamps: UTC ISO-8601 text with milliseconds, fixed width (24 characters), as in 001.
-- Curves are JSON text [{"name":"lift","kind":"position_time","time_step_s":0.01,
-- "positions_mm":[...]}, {"name":"cut","kind":"linmot","curve_id":7,...}] in written order: a
-- version is read and written whole, never queried by curve (decision 411).

CREATE TABLE curve_sets (
  name        TEXT    PRIMARY KEY
              CHECK (length(name) BETWEEN 1 AND 128 AND name NOT GLOB '*[^A-Za-z0-9._-]*'),
  description TEXT    NOT NULL DEFAULT '',
  created_at  TEXT    NOT NULL CHECK (length(created_at) = 24),
  updated_at  TEXT    NOT NULL CHECK (length(updated_at) = 24),
  version     INTEGER NOT NULL CHECK (version >= 1),
  etag        TEXT    NOT NULL CHECK (etag <> '')
);

CREATE TABLE curve_set_versions (
  set_name    TEXT    NOT NULL REFERENCES curve_sets (name) ON DELETE CASCADE,
  version     INTEGER NOT NULL CHECK (version >= 1),
  author      TEXT    NOT NULL,
  comment     TEXT    NOT NULL,
  created_at  TEXT    NOT NULL CHECK (length(created_at) = 24),
  curves_json TEXT    NOT NULL CHECK (json_valid(curves_json) AND json_type(curves_json) = 'array'),
  PRIMARY KEY (set_name, version)
);

-- A version is history: never changed, removed only together with its set (the cascade of
-- DELETE FROM curve_sets runs after the set row is gone, so the WHEN clause lets it pass).
CREATE TRIGGER curve_set_versions_no_update BEFORE UPDATE ON curve_set_versions
BEGIN
  SELECT RAISE(ABORT, 'curve_set_versions are immutable');
END;

CREATE TRIGGER curve_set_versions_no_delete BEFORE DELETE ON curve_set_versions
WHEN EXISTS (SELECT 1 FROM curve_sets WHERE name = OLD.set_name)
BEGIN
  SELECT RAISE(ABORT, 'curve_set_versions are removed only with their set');
END;

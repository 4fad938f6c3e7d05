-- 001_initial: configuration snapshots and the append-only audit log.
-- Timestamps are UTC ISO-8601 text with milliseconds ("2024-05-01T12:00:00.123Z"): fixed width,
-- so text order is time order and `ts >= ?` works on the index.

CREATE TABLE drive_config_snapshots (
  id          INTEGER PRIMARY KEY,
  created_at  TEXT    NOT NULL,
  source      TEXT    NOT NULL,
  yaml        TEXT    NOT NULL,
  drive_count INTEGER NOT NULL CHECK (drive_count >= 0)
);

CREATE TABLE audit_log (
  id             INTEGER PRIMARY KEY,
  ts             TEXT    NOT NULL,
  principal      TEXT    NOT NULL,
  source_address TEXT    NOT NULL,
  drive          TEXT    NOT NULL,
  action         TEXT    NOT NULL,
  request_json   TEXT    NOT NULL,
  result_code    INTEGER NOT NULL,
  result_message TEXT    NOT NULL
);

-- Query() filters by drive or action and pages newest first by id.
CREATE INDEX audit_log_drive_id  ON audit_log (drive, id);
CREATE INDEX audit_log_action_id ON audit_log (action, id);
CREATE INDEX audit_log_ts        ON audit_log (ts);

-- The audit trail is evidence: rows are never changed or removed through SQL.
CREATE TRIGGER audit_log_no_update BEFORE UPDATE ON audit_log
BEGIN
  SELECT RAISE(ABORT, 'audit_log is append-only');
END;

CREATE TRIGGER audit_log_no_delete BEFORE DELETE ON audit_log
BEGIN
  SELECT RAISE(ABORT, 'audit_log is append-only');
END;

-- 007_apply_interrupted: an apply the gateway did not finish (killed, power lost) is reported
-- INTERRUPTED with its pre-images, and can be restored (issue 11 "Crash safety", decision 1441).
-- SQLite cannot change a CHECK constraint in place, so apply_operations is rebuilt the way the
-- SQLite manual prescribes (lang_altertable.html §7: new table, copy, drop, rename) inside this
-- migration's transaction. Rows, ids and the AUTOINCREMENT high-water mark are kept as they are.
--
-- New columns:
--   target_stored: RAM (0) or ROM (1) values, as the set said when the apply started; a restore
--     of the pre-image must write the same store. Old rows take their set's current flag (the
--     best that is known; 0 when the set is gone).
--   restores: "op-<n>" when this operation writes back the pre-image of operation n, else ''.

CREATE TABLE apply_operations_new (
  id            INTEGER PRIMARY KEY AUTOINCREMENT,
  set_name      TEXT    NOT NULL CHECK (set_name <> ''),
  set_version   INTEGER NOT NULL CHECK (set_version >= 0),
  dry_run       INTEGER NOT NULL CHECK (dry_run IN (0, 1)),
  state         TEXT    NOT NULL
                CHECK (state IN ('RUNNING', 'SUCCEEDED', 'FAILED', 'FAILED_ROLLBACK',
                                 'INTERRUPTED')),
  principal     TEXT    NOT NULL,
  created_at    TEXT    NOT NULL CHECK (length(created_at) = 24),
  updated_at    TEXT    NOT NULL CHECK (length(updated_at) = 24),
  drives_json   TEXT    NOT NULL CHECK (json_valid(drives_json) AND json_type(drives_json) = 'array'),
  target_stored INTEGER NOT NULL DEFAULT 0 CHECK (target_stored IN (0, 1)),
  restores      TEXT    NOT NULL DEFAULT '' CHECK (restores = '' OR restores GLOB 'op-[1-9]*')
);

INSERT INTO apply_operations_new (id, set_name, set_version, dry_run, state, principal,
                                  created_at, updated_at, drives_json, target_stored)
SELECT id, set_name, set_version, dry_run, state, principal, created_at, updated_at, drives_json,
       COALESCE((SELECT target_stored FROM parameter_sets WHERE name = o.set_name), 0)
FROM apply_operations AS o ORDER BY id;

-- The copy set the new table's counter to MAX(id); the old one may be higher only if ids were
-- handed out and rolled back, never reused either way: carry the old value over.
DELETE FROM sqlite_sequence WHERE name = 'apply_operations_new';
INSERT INTO sqlite_sequence (name, seq)
SELECT 'apply_operations_new', seq FROM sqlite_sequence WHERE name = 'apply_operations';

DROP TRIGGER apply_operations_fixed_columns;
DROP TRIGGER apply_operations_no_delete;
DROP TABLE apply_operations;
ALTER TABLE apply_operations_new RENAME TO apply_operations;

-- As in 002, plus the two new fixed columns.
CREATE TRIGGER apply_operations_fixed_columns
BEFORE UPDATE OF id, set_name, set_version, dry_run, principal, created_at, target_stored, restores
ON apply_operations
WHEN NEW.id IS NOT OLD.id OR NEW.set_name IS NOT OLD.set_name
  OR NEW.set_version IS NOT OLD.set_version OR NEW.dry_run IS NOT OLD.dry_run
  OR NEW.principal IS NOT OLD.principal OR NEW.created_at IS NOT OLD.created_at
  OR NEW.target_stored IS NOT OLD.target_stored OR NEW.restores IS NOT OLD.restores
BEGIN
  SELECT RAISE(ABORT, 'apply_operations: only state, drives and updated_at change');
END;

CREATE TRIGGER apply_operations_no_delete BEFORE DELETE ON apply_operations
BEGIN
  SELECT RAISE(ABORT, 'apply_operations are never deleted');
END;

-- Start-up looks for RUNNING rows (there are none or few): a partial index keeps that a look-up.
CREATE INDEX apply_operations_running ON apply_operations (id) WHERE state = 'RUNNING';

-- 005_audit_chain: the audit trail as a hash chain with the IEC 62443-4-2 CR 2.8 fields (issue 7,
-- decision 017). Rows written before this migration keep seq NULL and an empty hash: they are
-- not chained; the first chained row (the genesis anchor, written by storage/audit_log.cpp on the
-- first append) records how many there were and a digest over them.

ALTER TABLE audit_log ADD COLUMN seq         INTEGER;  -- 1, 2, 3, ... in append order
ALTER TABLE audit_log ADD COLUMN role        TEXT NOT NULL DEFAULT '';
ALTER TABLE audit_log ADD COLUMN before_json TEXT NOT NULL DEFAULT '';  -- '' = no state change
ALTER TABLE audit_log ADD COLUMN after_json  TEXT NOT NULL DEFAULT '';
ALTER TABLE audit_log ADD COLUMN prev_hash   TEXT NOT NULL DEFAULT '';  -- lowercase hex SHA-256
ALTER TABLE audit_log ADD COLUMN hash        TEXT NOT NULL DEFAULT '';

CREATE UNIQUE INDEX audit_log_seq ON audit_log (seq);
CREATE INDEX audit_log_principal_id ON audit_log (principal, id);

-- Rows only join the chain at its end, one sequence number after the last, with both hashes
-- (the linear chain is the database's rule too, not only the code's).
CREATE TRIGGER audit_log_chain_append BEFORE INSERT ON audit_log
WHEN NEW.seq IS NULL
  OR NEW.seq IS NOT COALESCE((SELECT MAX(seq) FROM audit_log), 0) + 1
  OR length(NEW.hash) <> 64 OR length(NEW.prev_hash) <> 64
BEGIN
  SELECT RAISE(ABORT, 'audit_log: rows are only appended to the end of the hash chain');
END;

-- Retention (decision 017): the oldest rows are removed only by AuditLog's pruning path, which
-- holds the guard row for the length of its own transaction and writes an "audit.pruned" anchor
-- carrying the hash of the last removed row. Any other DELETE is still refused.
CREATE TABLE audit_prune_guard (
  id INTEGER PRIMARY KEY CHECK (id = 1)
);

DROP TRIGGER audit_log_no_delete;
CREATE TRIGGER audit_log_no_delete BEFORE DELETE ON audit_log
WHEN NOT EXISTS (SELECT 1 FROM audit_prune_guard)
BEGIN
  SELECT RAISE(ABORT, 'audit_log is append-only');
END;

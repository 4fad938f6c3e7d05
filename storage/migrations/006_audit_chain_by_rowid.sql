-- 006_audit_chain_by_rowid: the chain's order is the row id's order, so the unique index on seq
-- goes (one b-tree less per append: issue 10 P6, decision 1351). Rows, ids, seq and hashes stay
-- exactly as they are (no rebuild): since 005 every row was appended by the chain trigger with
-- an automatic id (MAX(id) + 1) and seq = MAX(seq) + 1, so id order already is seq order.

DROP INDEX audit_log_seq;

-- Rows from before the chain (seq NULL, decision 017) keep an index of their own: counting them
-- and finding the last one stays a look-up. Chained rows are not in it (partial index), so an
-- append writes nothing here.
CREATE INDEX audit_log_legacy_id ON audit_log (id) WHERE seq IS NULL;

-- Before the row goes in: it joins the chain one seq after the newest row (the one with the
-- highest id: MAX(id) and the row are two descents of the table's own b-tree), with both hashes.
DROP TRIGGER audit_log_chain_append;
CREATE TRIGGER audit_log_chain_append BEFORE INSERT ON audit_log
WHEN NEW.seq IS NULL
  OR NEW.seq IS NOT COALESCE(
       (SELECT seq FROM audit_log WHERE id = (SELECT MAX(id) FROM audit_log)), 0) + 1
  OR length(NEW.hash) <> 64 OR length(NEW.prev_hash) <> 64
BEGIN
  SELECT RAISE(ABORT, 'audit_log: rows are only appended to the end of the hash chain');
END;

-- After it went in (NEW.id is only known here): it is the newest row and directly follows its
-- predecessor by id. This refuses an explicit id below the newest (which would put a row into
-- the middle of the chain) and an INSERT OR REPLACE of an existing row (REPLACE deletes without
-- firing audit_log_no_delete; the old unique seq index made that case fail as a gap).
CREATE TRIGGER audit_log_chain_position AFTER INSERT ON audit_log
WHEN NEW.id IS NOT (SELECT MAX(id) FROM audit_log)
  OR NEW.seq IS NOT COALESCE(
       (SELECT seq FROM audit_log WHERE id < NEW.id ORDER BY id DESC LIMIT 1), 0) + 1
BEGIN
  SELECT RAISE(ABORT, 'audit_log: rows are only appended to the end of the hash chain');
END;

-- 004_auth_tokens: API bearer tokens (issue 7 "Authentication and authorisation", decision 015).
-- Timestamps as in 001: UTC ISO-8601 text with milliseconds, fixed width (24 characters).
-- The secret itself is never stored: only a random 16-byte salt and SHA-256(salt || secret),
-- both as lower-case hex. The token handed out once is "dgw_<id>_<secret>"; <id> finds the row,
-- the hash proves the secret.

CREATE TABLE api_tokens (
  id          TEXT    PRIMARY KEY CHECK (length(id) BETWEEN 1 AND 32 AND id NOT GLOB '*[^0-9a-f]*'),
  name        TEXT    NOT NULL
              CHECK (length(name) BETWEEN 1 AND 128 AND name NOT GLOB '*[^A-Za-z0-9._-]*'),
  role        TEXT    NOT NULL CHECK (role IN ('viewer', 'operator', 'engineer', 'admin')),
  salt        TEXT    NOT NULL CHECK (length(salt) = 32 AND salt NOT GLOB '*[^0-9a-f]*'),
  secret_hash TEXT    NOT NULL
              CHECK (length(secret_hash) = 64 AND secret_hash NOT GLOB '*[^0-9a-f]*'),
  created_at  TEXT    NOT NULL CHECK (length(created_at) = 24),
  revoked_at  TEXT             CHECK (revoked_at IS NULL OR length(revoked_at) = 24),
  last_used   TEXT             CHECK (last_used IS NULL OR length(last_used) = 24)
);

-- A name names at most one live token (revoke NAME is unambiguous); a revoked token's name may
-- be reused, the old row stays as history.
CREATE UNIQUE INDEX api_tokens_live_name ON api_tokens (name) WHERE revoked_at IS NULL;

-- What a token is (id, name, role, salt, hash, creation) never changes; revocation is one way.
CREATE TRIGGER api_tokens_fixed_columns
BEFORE UPDATE OF id, name, role, salt, secret_hash, created_at ON api_tokens
WHEN NEW.id IS NOT OLD.id OR NEW.name IS NOT OLD.name OR NEW.role IS NOT OLD.role
  OR NEW.salt IS NOT OLD.salt OR NEW.secret_hash IS NOT OLD.secret_hash
  OR NEW.created_at IS NOT OLD.created_at
BEGIN
  SELECT RAISE(ABORT, 'api_tokens: only revoked_at and last_used change');
END;

CREATE TRIGGER api_tokens_revocation_final
BEFORE UPDATE OF revoked_at ON api_tokens
WHEN OLD.revoked_at IS NOT NULL AND NEW.revoked_at IS NOT OLD.revoked_at
BEGIN
  SELECT RAISE(ABORT, 'api_tokens: a revoked token stays revoked');
END;

CREATE TRIGGER api_tokens_no_delete BEFORE DELETE ON api_tokens
BEGIN
  SELECT RAISE(ABORT, 'api_tokens are revoked, never deleted');
END;

"""Key ids never reused: ``api_keys.id`` AUTOINCREMENT on SQLite.

SQLite gives a new row of an ``INTEGER PRIMARY KEY`` the largest id plus
one, so a key created after the newest was revoked got the revoked key's id:
a ``keys revoke ID`` written down for the old key would revoke the new one.
With AUTOINCREMENT, SQLite keeps the largest id it ever gave
(``sqlite_sequence``) and never gives it again. The table is rebuilt (SQLite
cannot alter a primary key), its rows and their ids kept; ids revoked before
this migration above the largest kept are not known and may be given once
more. PostgreSQL's sequences never reuse an id: there it changes nothing.

Revision ID: 0007
Revises: 0006
"""

from __future__ import annotations

from alembic import op

revision = "0007"
down_revision = "0006"
branch_labels = None
depends_on = None


def upgrade() -> None:
    if op.get_bind().dialect.name != "sqlite":
        return
    with op.batch_alter_table("api_keys", recreate="always", table_kwargs={"sqlite_autoincrement": True}):
        pass  # the table copied whole into one declared AUTOINCREMENT


def downgrade() -> None:
    if op.get_bind().dialect.name != "sqlite":
        return
    with op.batch_alter_table("api_keys", recreate="always", table_kwargs={"sqlite_autoincrement": False}):
        pass

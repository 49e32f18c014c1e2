#!/bin/sh
# The stand-in PostgreSQL's entry point (docker/test/postgres.Dockerfile): a first start creates the
# cluster with the user, password (from its secret file) and database the environment names; every
# start runs the server in the foreground as the postgres user, listening on every address. The
# cluster is UTF-8, as the official image's is (a minimal Debian has no locale: initdb would choose
# SQL_ASCII, whose text drivers hand back as bytes).
set -eu
bin=$(ls -d /usr/lib/postgresql/*/bin | sort -V | tail -n 1)
mkdir -p "$PGDATA" /run/postgresql
chown postgres:postgres "$PGDATA" /run/postgresql
chmod 0700 "$PGDATA"
if [ ! -s "$PGDATA/PG_VERSION" ]; then
    install -o postgres -m 0600 "$POSTGRES_PASSWORD_FILE" /tmp/password
    su postgres -s /bin/sh -c "$bin/initdb -D '$PGDATA' -U '$POSTGRES_USER' --pwfile=/tmp/password \
        --encoding=UTF8 --locale=C.UTF-8 --auth-local=trust --auth-host=scram-sha-256" > /dev/null
    rm -f /tmp/password
    echo "host all all 0.0.0.0/0 scram-sha-256" >> "$PGDATA/pg_hba.conf"
    su postgres -s /bin/sh -c "$bin/pg_ctl -D '$PGDATA' -o \"-c listen_addresses=''\" -w start" > /dev/null
    su postgres -s /bin/sh -c "$bin/psql -q -U '$POSTGRES_USER' -d postgres -c 'CREATE DATABASE \"$POSTGRES_DB\"'"
    su postgres -s /bin/sh -c "$bin/pg_ctl -D '$PGDATA' -m fast -w stop" > /dev/null
fi
exec su postgres -s /bin/sh -c "exec $bin/postgres -D '$PGDATA' -c listen_addresses='*'"

# A stand-in for the official PostgreSQL image, made from Debian's packages, for `make check-container`
# on machines that reach no image registry: the same environment (POSTGRES_USER, POSTGRES_DB,
# POSTGRES_PASSWORD_FILE), port, data folder and pg_isready as the image the compose file pins.
ARG BASE
FROM ${BASE}
COPY docker/test/postgres-entrypoint.sh /usr/local/bin/postgres-entrypoint
RUN chmod 0755 /usr/local/bin/postgres-entrypoint && command -v pg_isready
ENV PGDATA=/var/lib/postgresql/data
EXPOSE 5432
ENTRYPOINT ["/usr/local/bin/postgres-entrypoint"]

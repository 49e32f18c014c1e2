# The reverse proxy in front of the API (docker/compose.yaml's `proxy`): Debian's nginx on the same
# base as the product's image (pinned by digest; BASE replaces it as for docker/Dockerfile). Its
# configuration, docker/nginx.conf, is mounted by the compose file; it runs as www-data, without
# privileges, on port 8443.
ARG BASE=python:3.11-slim-bookworm@sha256:a36c24f9cbdf4fd0f52d67f0823eeac19c2028c637cecc392d97f980d4fec56b
FROM ${BASE}
RUN apt-get update \
    && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends nginx \
    && rm -rf /var/lib/apt/lists/* \
    && nginx -v
USER www-data
EXPOSE 8443
ENTRYPOINT ["nginx", "-g", "daemon off;"]

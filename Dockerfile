# sceneloc-server in a container: a build stage that makes the Debian package
# (scripts/package.sh), and a slim runtime stage that installs it.
#
#   docker build -t sceneloc .
#   docker run -d --name sceneloc -p 5555:5555 -v "$PWD/maps:/maps" sceneloc
#   docker run -d ... sceneloc --threads 4 --log-level debug   # extra sceneloc-server flags
#   docker kill -s HUP sceneloc                                # reload every map in /maps
#
# The maps folder is a volume: every *.scnl in it is served under its file stem. The image
# also holds the client (`sceneloc`), which the health check uses, and the tools
# `sceneloc-train`, `sceneloc-gentour` and `sceneloc-eval`, so a map can be made inside the
# container. The package's own check runs in the image as root:
#   ../shared/tools/container-check -- sh /usr/share/sceneloc/check-package.sh

# ---------------------------------------------------------------- build
FROM debian:bookworm AS build
WORKDIR /src
# The package list first, so the slow install is cached across source changes.
COPY scripts/setup.sh scripts/setup.sh
RUN bash scripts/setup.sh && rm -rf /var/lib/apt/lists/*
COPY . .
# The Debian package (scripts/package.sh: portable binaries without AVX2, no tests or
# benchmarks); SCENELOC_VERSION names the build where the context has no .git.
ARG SCENELOC_VERSION=""
RUN SCENELOC_VERSION="$SCENELOC_VERSION" bash scripts/package.sh /out

# ---------------------------------------------------------------- runtime
FROM debian:bookworm-slim
# The image's user first (uid 10001, as volumes and Kubernetes manifests expect); the
# package keeps a user it finds. apt installs the package with exactly the shared
# libraries its binaries link (dpkg-shlibdeps), and the package's maps folder, settings in
# /etc/sceneloc and systemd unit come with it (the unit is unused in a container).
#
# OpenCV's core links libGLX.so.0, whose package depends on Mesa's GLX library and through it
# on Mesa's drivers, LLVM, Z3 and ICU (about 200 MB); sceneloc never makes a GL context, and
# libglvnd loads a GLX vendor only when one is made. An empty package that provides Mesa's
# GLX library (deploy/docker/headless-glx.control) is installed first, so apt leaves them out.
RUN useradd --uid 10001 --user-group --no-create-home --home-dir /nonexistent \
      --shell /usr/sbin/nologin sceneloc
COPY deploy/docker/headless-glx.control /tmp/headless-glx/DEBIAN/control
COPY --from=build /out/sceneloc_*.deb /tmp/
RUN dpkg-deb --build /tmp/headless-glx /tmp/headless-glx.deb >/dev/null \
 && dpkg -i /tmp/headless-glx.deb \
 && apt-get update -qq \
 && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends /tmp/sceneloc_*.deb \
 && apt-get clean \
 && rm -rf /var/lib/apt/lists/* /var/cache/apt/*.bin /tmp/sceneloc_*.deb /tmp/headless-glx* \
 && mkdir -p /maps && chown sceneloc:sceneloc /maps
VOLUME /maps
EXPOSE 5555
USER sceneloc
# Healthy when the server answers a Stats request (answered by its I/O thread, so it stays
# fast under load): up to 3 attempts (the client retries twice) of 2 s each.
HEALTHCHECK --interval=30s --timeout=10s --start-period=10s --retries=3 \
  CMD ["sceneloc", "stats", "--server", "tcp://127.0.0.1:5555", "--timeout-ms", "2000"]
# SIGTERM (docker stop) drains in-flight requests and exits 0; SIGHUP reloads the maps.
ENTRYPOINT ["sceneloc-server", "--config", "/etc/sceneloc/server.yaml", "--maps", "/maps", \
            "--endpoint", "tcp://*:5555"]

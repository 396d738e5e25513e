# sceneloc-server in a container: a build stage with the -dev packages, and a slim runtime
# stage with only the shared libraries the binaries link.
#
#   docker build -t sceneloc .
#   docker run -d --name sceneloc -p 5555:5555 -v "$PWD/maps:/maps" sceneloc
#   docker run -d ... sceneloc --threads 4 --log-level debug   # extra sceneloc-server flags
#   docker kill -s HUP sceneloc                                # reload every map in /maps
#
# The maps folder is a volume: every *.scnl in it is served under its file stem. The image
# also holds the client (`sceneloc`), which the health check uses, and the small tools
# `sceneloc-train` and `sceneloc-gentour`, so a map can be made inside the container.

# ---------------------------------------------------------------- build
FROM debian:bookworm AS build
WORKDIR /src
# The package list first, so the slow install is cached across source changes.
COPY scripts/setup.sh scripts/setup.sh
RUN bash scripts/setup.sh && rm -rf /var/lib/apt/lists/*
COPY . .
# Portable binaries (no AVX2), without tests and benchmarks.
RUN cmake -S . -B /build -G Ninja -DCMAKE_BUILD_TYPE=Release -DSCENELOC_AVX2=OFF \
      -DSCENELOC_BUILD_TESTS=OFF -DSCENELOC_BUILD_BENCHMARKS=OFF \
 && cmake --build /build -j"$(nproc)" \
      --target sceneloc-server sceneloc-broker sceneloc sceneloc-train sceneloc-gentour \
 && strip /build/server/sceneloc-server /build/server/sceneloc-broker /build/client/sceneloc \
      /build/tools/sceneloc-train /build/tools/sceneloc-gentour

# ---------------------------------------------------------------- runtime
FROM debian:bookworm-slim
# Exactly the libraries the five binaries link (readelf -d ... | grep NEEDED), Debian 12 names.
RUN apt-get update -qq \
 && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      libopencv-core406 libopencv-imgproc406 libopencv-imgcodecs406 \
      libopencv-features2d406 libopencv-calib3d406 \
      libprotobuf32 libzmq5 libspdlog1.10 libfmt9 libyaml-cpp0.7 \
      libprometheus-cpp-core1.0 libcivetweb1 \
 && rm -rf /var/lib/apt/lists/*
COPY --from=build /build/server/sceneloc-server /build/server/sceneloc-broker /build/client/sceneloc \
     /build/tools/sceneloc-train /build/tools/sceneloc-gentour /usr/local/bin/
COPY configs/ /etc/sceneloc/
RUN useradd --uid 10001 --user-group --no-create-home --home-dir /nonexistent \
      --shell /usr/sbin/nologin sceneloc \
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

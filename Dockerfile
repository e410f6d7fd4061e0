# fishfsi on Debian 12 with OpenFOAM v1912 (Debian's package) and the Python packages in .venv.
#   docker build -t fishfsi .
#   docker run --rm -v "$PWD/out:/work/out" fishfsi cases/fixed_head_3Hz --output /work/out --json
#   docker run --rm --entrypoint bash fishfsi scripts/test.sh -q     # the test suite
# The image is built by the same scripts/setup.sh as a bare machine (README, "Two commands").
FROM debian:12

ENV DEBIAN_FRONTEND=noninteractive LANG=C.UTF-8
WORKDIR /opt/fishfsi
COPY . .
# apt (OpenFOAM, the libraries the gmsh/VTK wheels load) and .venv, as root; then a user of its
# own, so that the persistent OpenFOAM driver runs as that user rather than as 'nobody'
RUN bash scripts/setup.sh \
    && rm -rf /var/lib/apt/lists/* /root/.cache/pip \
    && useradd --create-home --shell /bin/bash fish \
    && mkdir -p /work/out \
    && chown -R fish:fish /opt/fishfsi /work
USER fish
ENV PATH=/opt/fishfsi/.venv/bin:$PATH
ENTRYPOINT ["fsi-run"]
CMD ["cases/fixed_head_3Hz"]

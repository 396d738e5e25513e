"""Builds the sceneloc package, compiling proto/sceneloc.proto into it with protoc.

The proto is read from ../../proto/sceneloc.proto beside this file (the checkout's layout),
and the generated sceneloc/sceneloc_pb2.py is written into the build directory only (never
the source tree, never committed). PROTOC names the protoc to run (default: protoc on PATH).
"""
import os
import shutil
import subprocess
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent


def compile_proto(out_dir: Path) -> None:
    """Runs protoc --python_out on the wire protocol into `out_dir`."""
    proto = HERE.parent.parent / "proto" / "sceneloc.proto"
    if not proto.is_file():
        raise SystemExit(f"sceneloc: no proto file at {proto} (build from a checkout)")
    protoc = os.environ.get("PROTOC") or shutil.which("protoc")
    if protoc is None:
        raise SystemExit("sceneloc: protoc not found (Debian: protobuf-compiler; or set PROTOC)")
    out_dir.mkdir(parents=True, exist_ok=True)
    subprocess.run(
        [protoc, f"-I{proto.parent}", f"--python_out={out_dir}", proto.name], check=True
    )


class BuildPyWithProto(build_py):
    """build_py, then the proto compiled into the built package."""

    def run(self) -> None:
        super().run()
        if not self.dry_run:
            compile_proto(Path(self.build_lib) / "sceneloc")


setup(cmdclass={"build_py": BuildPyWithProto})

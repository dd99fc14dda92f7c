"""Writes the FileDescriptorSet of ASAM OSI's GroundTruth (osi_groundtruth.proto
and every file it imports, dependencies first) from the `osi-python` package,
whose generated *_pb2 modules carry each .proto file's serialized
FileDescriptorProto. litesim-mcap's build.rs generates Rust from it with prost
(no protoc anywhere) and embeds it as the MCAP channel's schema.

    python3 -m pip install osi-python==3.8.0
    python3 crates/litesim-mcap/tools/gen_osi_descriptors.py crates/litesim-mcap/osi/osi3.fds.bin
"""
import importlib
import sys
from importlib import metadata

from google.protobuf import descriptor_pb2


def main(out):
    root = importlib.import_module("osi3.osi_groundtruth_pb2").DESCRIPTOR
    done, order = set(), []

    def visit(fd):
        # Post-order: every file after the files it imports.
        if fd.name in done:
            return
        done.add(fd.name)
        for dep in fd.dependencies:
            visit(dep)
        order.append(fd)

    visit(root)
    fds = descriptor_pb2.FileDescriptorSet()
    for fd in order:
        fd.CopyToProto(fds.file.add())
    with open(out, "wb") as f:
        f.write(fds.SerializeToString())
    print(f"wrote {out}: {len(order)} files from osi-python {metadata.version('osi-python')}")


if __name__ == "__main__":
    main(sys.argv[1])

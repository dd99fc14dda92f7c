"""Lists a server's services through gRPC reflection with grpcio's own
reflection client (which speaks grpc.reflection.v1alpha).

Usage: python3 reflection_client.py HOST:PORT
Prints one service name per line.
"""
import sys

import grpc
from grpc_reflection.v1alpha.proto_reflection_descriptor_database import (
    ProtoReflectionDescriptorDatabase,
)

db = ProtoReflectionDescriptorDatabase(grpc.insecure_channel(sys.argv[1]))
for name in db.get_services():
    print(name)

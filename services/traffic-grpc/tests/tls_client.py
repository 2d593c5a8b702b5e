"""The traffic service over mutual TLS, as a runtime with the deployment's
certificates calls it: with its client certificate it gets the metadata;
without one, or without TLS, it is refused. Prints OK.

usage: tls_client.py <generated stubs dir> <address> <certificate dir of make-certs.sh>
"""

import os
import sys

sys.path.insert(0, sys.argv[1])

import grpc  # noqa: E402
import common_pb2 as common  # noqa: E402
import traffic_pb2_grpc  # noqa: E402

address, certs = sys.argv[2], sys.argv[3]


def read(name):
    with open(os.path.join(certs, name), "rb") as f:
        return f.read()


def metadata(channel):
    return traffic_pb2_grpc.TrafficServiceStub(channel).get_metadata(common.Empty(), timeout=10)


# The `runtime` identity of deploy/secure/make-certs.sh.
mutual = grpc.ssl_channel_credentials(read("ca.pem"), read("runtime.key"), read("runtime.pem"))
assert metadata(grpc.secure_channel(address, mutual)).minimum_history_length_us == 1_000_000

for name, channel in [
    ("TLS without a client certificate", grpc.secure_channel(address, grpc.ssl_channel_credentials(read("ca.pem")))),
    ("plain text", grpc.insecure_channel(address)),
]:
    try:
        metadata(channel)
    except grpc.RpcError as e:
        assert e.code() == grpc.StatusCode.UNAVAILABLE, (name, e.code(), e.details())
    else:
        raise AssertionError(f"{name} was served")
print("OK")

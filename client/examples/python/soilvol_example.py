#!/usr/bin/python3
"""A soilvol client in Python (Debian's python3-grpcio, stubs from generate.sh): server info,
register a container from an empty scan, estimate a scan with an idempotency key, page through
the containers, and read the google.rpc.Status details of an error.

  client/examples/python/generate.sh /tmp/soilvol-py
  PYTHONPATH=/tmp/soilvol-py client/examples/python/soilvol_example.py \\
      --server localhost:50051 --empty empty.ply --corners="x,y,z;x,y,z;x,y,z;x,y,z" --scan scan.ply
"""
import argparse
import sys

import grpc
from google.rpc import error_details_pb2, status_pb2
from soilvol.v1 import soilvol_pb2 as pb
from soilvol.v1 import soilvol_pb2_grpc as pb_grpc


def opening(text):
    corners = []
    for corner in text.split(";"):
        x, y, z = (float(v) for v in corner.split(","))
        corners.append(pb.Point3(x=x, y=y, z=z))
    return pb.Opening(corners=corners)


def explain(error):
    """What a failed call's google.rpc.Status says (the grpc-status-details-bin trailer)."""
    print(f"error: {error.code().name}: {error.details()}")
    for key, value in error.trailing_metadata() or ():
        if key != "grpc-status-details-bin":
            continue
        for detail in status_pb2.Status.FromString(value).details:
            if detail.Is(error_details_pb2.ErrorInfo.DESCRIPTOR):
                info = error_details_pb2.ErrorInfo()
                detail.Unpack(info)
                print(f"  reason {info.reason} (domain {info.domain}), "
                      f"field {info.metadata.get('field', '')!r}")
            elif detail.Is(error_details_pb2.BadRequest.DESCRIPTOR):
                bad = error_details_pb2.BadRequest()
                detail.Unpack(bad)
                for violation in bad.field_violations:
                    print(f"  bad field {violation.field}: {violation.description}")
            elif detail.Is(error_details_pb2.RetryInfo.DESCRIPTOR):
                retry = error_details_pb2.RetryInfo()
                detail.Unpack(retry)
                print(f"  retry after {retry.retry_delay.ToTimedelta()}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--server", default="localhost:50051")
    parser.add_argument("--id", default="python-example")
    parser.add_argument("--empty", required=True, help="PLY or PCD of the empty container")
    parser.add_argument("--corners", required=True, help="x,y,z;x,y,z;x,y,z;x,y,z")
    parser.add_argument("--scan", required=True, help="PLY or PCD of the filled container")
    args = parser.parse_args()

    with grpc.insecure_channel(args.server) as channel:
        stub = pb_grpc.SoilVolumeStub(channel)
        metadata = [("x-request-id", "python-example-1")]
        info = stub.GetServerInfo(pb.GetServerInfoRequest(), timeout=10, metadata=metadata)
        print(f"server {info.version} ({info.revision})")

        with open(args.empty, "rb") as f:
            empty = f.read()
        try:
            container = stub.RegisterContainer(pb.RegisterContainerRequest(
                container_id=args.id, overwrite=True, scan=pb.Scan(cloud=pb.CloudScan(data=empty)),
                opening=opening(args.corners)), timeout=60, metadata=metadata)
        except grpc.RpcError as error:
            explain(error)
            return 1
        print(f"registered {container.container_id}: struck capacity "
              f"{1000 * container.struck_capacity_m3:.1f} L, etag {container.etag}")

        with open(args.scan, "rb") as f:
            scan = pb.Scan(cloud=pb.CloudScan(data=f.read()))
        try:
            estimate = stub.EstimateVolume(pb.EstimateVolumeRequest(
                container_id=args.id, scan=scan, request_id="python-load-1",
                material_density_kg_m3=1600), timeout=60, metadata=metadata)
        except grpc.RpcError as error:
            explain(error)
            return 1
        print(f"volume {1000 * estimate.volume_m3:.1f} L +- {1000 * estimate.uncertainty_m3:.1f} L, "
              f"mass {estimate.mass_kg:.0f} kg")

        count, token = 0, ""
        while True:
            page = stub.ListContainers(pb.ListContainersRequest(page_size=2, page_token=token),
                                       timeout=10, metadata=metadata)
            count += len(page.containers)
            token = page.next_page_token
            if not token:
                break
        print(f"containers: {count}")

        try:  # a mistake on purpose: the error names the field
            stub.EstimateVolume(pb.EstimateVolumeRequest(container_id=args.id, scan=scan,
                                                         grid_cell_m=0.0), timeout=60)
            print("a zero grid cell was accepted")
            return 1
        except grpc.RpcError as error:
            explain(error)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""semmap: a Python client for semmapd, the semantic map service.

    import semmap
    with semmap.Client("localhost:50051") as client:
        for event in client.ingest("path/to/tum_sequence", map="home"):
            ...
        print(client.where("laptop", map="home"))

Every failure raises semmap.SemmapError (its .code is the gRPC status code).
"""
from .client import Client, IngestStream
from .datasets import open_dataset, read_tum_trajectory
from .errors import SemmapError
from .poses import pose_matrix, quaternion_xyzw
from .types import (Ack, Camera, Export, MapInfo, ObjectInstance, ObjectType, Progress,
                    SessionInfo, Started, Summary)

__all__ = ["Ack", "Camera", "Client", "Export", "IngestStream", "MapInfo", "ObjectInstance",
           "ObjectType", "Progress", "SemmapError", "SessionInfo", "Started", "Summary",
           "open_dataset", "pose_matrix", "quaternion_xyzw", "read_tum_trajectory"]
__version__ = "0.1.0"

"""The one exception the client raises."""
import grpc


class SemmapError(Exception):
    """A call failed: `code` is the gRPC status code (grpc.StatusCode), `message` the server's
    (or the transport's) explanation, e.g. NOT_FOUND "no map 'kitchen'"."""

    def __init__(self, code: grpc.StatusCode, message: str):
        super().__init__(f"{code.name}: {message}")
        self.code = code
        self.message = message

    @classmethod
    def from_rpc_error(cls, error: grpc.RpcError) -> "SemmapError":
        code = error.code() if hasattr(error, "code") else grpc.StatusCode.UNKNOWN
        details = error.details() if hasattr(error, "details") else str(error)
        return cls(code or grpc.StatusCode.UNKNOWN, details or "")

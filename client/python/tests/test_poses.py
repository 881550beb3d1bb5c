import numpy as np

from semmap import pose_matrix, quaternion_xyzw


def test_quaternion_round_trip_over_many_rotations():
    rng = np.random.default_rng(7)
    for _ in range(200):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        q = -q if q[3] < 0 else q
        T = pose_matrix([1, 2, 3], q)
        assert np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)
        assert np.allclose(quaternion_xyzw(T[:3, :3]), q, atol=1e-9)
        assert np.allclose(T[:3, 3], [1, 2, 3])

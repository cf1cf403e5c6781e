"""High-precision (mpmath) references shared by the stress tests."""

import mpmath


def mp_attitude_error(q, reference):
    """``2 atan2(|vec(q_ref* ⊗ q)|, |scalar|)`` at the current mpmath precision (sign-invariant).

    ``q`` is a float quaternion (w, x, y, z); ``reference`` a sequence of mpmath numbers.
    """
    r = [mpmath.mpf(float(c)) for c in q]
    a = reference
    w = a[0] * r[0] + a[1] * r[1] + a[2] * r[2] + a[3] * r[3]
    x = a[0] * r[1] - a[1] * r[0] - a[2] * r[3] + a[3] * r[2]
    y = a[0] * r[2] + a[1] * r[3] - a[2] * r[0] - a[3] * r[1]
    z = a[0] * r[3] - a[1] * r[2] + a[2] * r[1] - a[3] * r[0]
    return float(2 * mpmath.atan2(mpmath.sqrt(x * x + y * y + z * z), abs(w)))

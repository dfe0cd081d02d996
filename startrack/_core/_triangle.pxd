# Planar-triangle arithmetic (Cole and Crassidis, 2006) shared by the triangle table's
# build, the triangle lookups and the hybrid search: chord sides, handedness, area and
# polar moment, and the features' sigmas. Each number is computed with numpy's operations
# in numpy's order (np.linalg.norm along an axis sums the squares in order), so that the
# database build, a lookup and the numpy reference agree to the bit.

cimport cython
from libc.math cimport fabs, sqrt

cdef struct Shape:
    double area
    double polar


cdef struct Features:
    double area
    double polar
    double sigma_area
    double sigma_polar


cdef inline double chord(const double* u, const double* w) noexcept nogil:
    """|u - w| of two 3-vectors."""
    cdef double dx = u[0] - w[0], dy = u[1] - w[1], dz = u[2] - w[2]
    return sqrt(dx * dx + dy * dy + dz * dz)


cdef inline double triple_product(const double* a, const double* b,
                                  const double* c) noexcept nogil:
    """a . (b x c): its sign is the triangle's handedness."""
    return (a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2])
            + a[2] * (b[0] * c[1] - b[1] * c[0]))


cdef inline double sign(double x) noexcept nogil:
    """np.sign: -1, 0 or +1, NaN for NaN."""
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return x


@cython.cdivision(True)  # divisors are norms of non-degenerate triangles
cdef inline Shape shape(const double* a, const double* b, const double* c) noexcept nogil:
    """Area (half the norm of the edges' cross product: Heron's area, accurate for thin
    triangles) and polar moment A (s1^2 + s2^2 + s3^2) / 36 of the planar triangle
    through the tips of a, b and c."""
    cdef double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2]
    cdef double wx = c[0] - a[0], wy = c[1] - a[1], wz = c[2] - a[2]
    cdef double cx = uy * wz - uz * wy, cy = uz * wx - ux * wz, cz = ux * wy - uy * wx
    cdef double s1 = chord(a, b), s2 = chord(b, c), s3 = chord(a, c)
    cdef Shape out
    out.area = 0.5 * sqrt(cx * cx + cy * cy + cz * cz)
    out.polar = out.area * (s1 * s1 + s2 * s2 + s3 * s3) / 36.0
    return out


cdef inline void _cross(const double* u, const double* w, double* out) noexcept nogil:
    out[0] = u[1] * w[2] - u[2] * w[1]
    out[1] = u[2] * w[0] - u[0] * w[2]
    out[2] = u[0] * w[1] - u[1] * w[0]


@cython.cdivision(True)  # divisors are norms of non-degenerate triangles
cdef inline void _tangent_basis(const double* v, double* t1, double* t2) noexcept nogil:
    """Two unit vectors orthogonal to ``v`` and to each other, as feature_sigmas takes
    them: v x e_k for the axis k of v's smallest component, then v x t1."""
    cdef double helper[3]
    cdef int axis = 0, i
    for i in range(1, 3):
        if fabs(v[i]) < fabs(v[axis]):
            axis = i
    helper[0] = helper[1] = helper[2] = 0.0
    helper[axis] = 1.0
    _cross(v, helper, t1)
    cdef double norm = sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2])
    for i in range(3):
        t1[i] = t1[i] / norm
    _cross(v, t1, t2)


@cython.cdivision(True)  # divisors are norms of non-degenerate triangles
cdef inline Features features(const double* v1, const double* v2, const double* v3,
                              double sigma) noexcept nogil:
    """(area, polar, sigma_area, sigma_polar) of one observed triple: first-order
    propagation of ``sigma`` per tangent axis by central differences, the numbers of
    startrack.database._triangles.feature_sigmas."""
    cdef double verts[3][3]
    cdef double v[3]
    cdef double basis[2][3]
    cdef double h = 1e-6  # feature_sigmas' central-difference step
    cdef double var_a = 0.0, var_j = 0.0, da, dj
    cdef Shape plus, minus
    cdef int n, i, b
    for i in range(3):
        verts[0][i], verts[1][i], verts[2][i] = v1[i], v2[i], v3[i]
    for n in range(3):
        for i in range(3):
            v[i] = verts[n][i]
        _tangent_basis(v, basis[0], basis[1])
        for b in range(2):
            for i in range(3):
                verts[n][i] = v[i] + h * basis[b][i]
            plus = shape(verts[0], verts[1], verts[2])
            for i in range(3):
                verts[n][i] = v[i] - h * basis[b][i]
            minus = shape(verts[0], verts[1], verts[2])
            da = (plus.area - minus.area) / (2 * h)
            dj = (plus.polar - minus.polar) / (2 * h)
            var_a += da * da
            var_j += dj * dj
        for i in range(3):
            verts[n][i] = v[i]
    cdef Shape mid = shape(verts[0], verts[1], verts[2])
    cdef Features out
    out.area, out.polar = mid.area, mid.polar
    out.sigma_area, out.sigma_polar = sigma * sqrt(var_a), sigma * sqrt(var_j)
    return out

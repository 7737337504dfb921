"""How much of a downward camera's view a rectangle on a horizontal plane covers, ROS-free and numpy-free.

The drone's optical flow measures its motion relative to what its bottom camera sees: over the ground,
its velocity; over the moving vehicle, its velocity relative to the vehicle; in between, a blend by how
much of the view the vehicle covers. The simulator's firmware (mujoco_sim) uses this to make the flow,
the landing stack (platform_tracking) to undo it, each from its own inputs (truth there, estimates here).

The footprint is the quadrilateral where the rays through the image corners meet the plane; the coverage
is its area inside the rectangle (Sutherland-Hodgman clipping) over its whole area.
"""
import math


def corner_rays(hfov_deg, aspect):
    """Directions of the image corners in the camera's optical frame (x right, y down, z forward), in order
    around the image, for a horizontal field of view ``hfov_deg`` [deg] and width / height ``aspect``."""
    tx = math.tan(math.radians(hfov_deg) / 2.0)
    ty = tx / aspect
    return ((-tx, -ty, 1.0), (tx, -ty, 1.0), (tx, ty, 1.0), (-tx, ty, 1.0))


def footprint(camera_position, world_from_optical, rays, plane_z):
    """Corners (x, y) where ``rays`` (optical frame) from the camera at ``camera_position`` (world [m]),
    turned by the 3x3 rotation ``world_from_optical`` (rows), meet the plane z = ``plane_z``; None if the
    camera is not above the plane or a ray does not point down to it."""
    # Plain floats: arithmetic on numpy's scalars, element by element, took twice as long.
    cx, cy, cz = (float(v) for v in camera_position)
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = ((float(v) for v in row) for row in world_from_optical)
    drop = float(plane_z) - cz
    if drop >= 0.0:
        return None
    corners = []
    for x, y, z in rays:
        wz = r20 * x + r21 * y + r22 * z
        if wz >= -1e-6:
            return None
        scale = drop / wz
        corners.append((cx + (r00 * x + r01 * y + r02 * z) * scale, cy + (r10 * x + r11 * y + r12 * z) * scale))
    return corners


def coverage(corners, centre_xy, yaw, rectangle):
    """Share of the polygon ``corners`` (world x, y, convex) inside ``rectangle`` (x_min, x_max, y_min,
    y_max) of a frame at ``centre_xy`` turned by ``yaw`` [rad]."""
    c, s = math.cos(yaw), math.sin(yaw)
    ox, oy = float(centre_xy[0]), float(centre_xy[1])
    local = [(c * (x - ox) + s * (y - oy), -s * (x - ox) + c * (y - oy)) for x, y in corners]
    whole = _area(local)
    if whole <= 1e-12:
        return 0.0
    x_min, x_max, y_min, y_max = rectangle
    # Wholly outside or wholly inside, the clipping below would give nothing or the polygon itself (the usual
    # cases: the view far from the vehicle, or low over it); the estimator asks seven times per navdata.
    xs, ys = [p[0] for p in local], [p[1] for p in local]
    if max(xs) < x_min or min(xs) > x_max or max(ys) < y_min or min(ys) > y_max:
        return 0.0
    if min(xs) >= x_min and max(xs) <= x_max and min(ys) >= y_min and max(ys) <= y_max:
        return 1.0
    inside = local
    for axis, bound, keep_below in ((0, x_min, False), (0, x_max, True), (1, y_min, False), (1, y_max, True)):
        inside = _clip(inside, axis, bound, keep_below)
        if not inside:
            return 0.0
    return min(1.0, _area(inside) / whole)


def _clip(polygon, axis, bound, keep_below):
    """The part of ``polygon`` on one side of the line ``p[axis] = bound`` (Sutherland-Hodgman)."""
    out = []
    previous = polygon[-1]
    previous_kept = previous[axis] <= bound if keep_below else previous[axis] >= bound
    for current in polygon:
        kept = current[axis] <= bound if keep_below else current[axis] >= bound
        if kept:
            if not previous_kept:
                out.append(_crossing(previous, current, axis, bound))
            out.append(current)
        elif previous_kept:
            out.append(_crossing(previous, current, axis, bound))
        previous, previous_kept = current, kept
    return out


def _crossing(a, b, axis, bound):
    f = (bound - a[axis]) / (b[axis] - a[axis])
    return (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]))


def _area(polygon):
    return 0.5 * abs(sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(polygon, polygon[1:] + polygon[:1])))


def surface_weight(share, low, high):
    """How much the flow follows the vehicle rather than the ground, from the share of the view the
    vehicle covers: 0 below ``low``, 1 above ``high``, a smooth step between."""
    x = min(1.0, max(0.0, (share - low) / (high - low)))
    return x * x * (3.0 - 2.0 * x)

"""Draw the side silhouettes of the shipped vehicle files from published dimensions.

Run ``python data/vehicles/draw_silhouettes.py`` to print, for each car, the
``silhouette_side`` and ``windscreen_top`` lines that its TOML file holds.

The outline is a polygon in the vehicle frame of the vehicle files: x forward from the
rear bumper, z up from the ground, metres. It is fixed by the car's published length,
height, wheelbase, front overhang and wheel radius, plus a body style ("sedan" or
"hatchback") that places the pillars. The points of the outline that are not published
dimensions (bumper heights, bonnet line, windscreen base, pillar positions) are set from
the proportions of mid-size cars: a reconstruction expert replaces them with a traced
outline (AutoView or a photograph) where one is at hand.
"""

from __future__ import annotations

import sys

# name: (length, height, wheelbase, front_overhang, wheel_radius, style)
CARS = {
    "audi_a4": (4.703, 1.427, 2.808, 0.903, 0.32, "sedan"),
    "toyota_camry_2018": (4.896, 1.445, 2.825, 0.975, 0.336, "sedan"),
    "vw_golf_7": (4.255, 1.452, 2.637, 0.867, 0.316, "hatchback"),
    "ford_focus_2012": (4.358, 1.484, 2.648, 0.910, 0.322, "hatchback"),
}


def outline(length, height, wheelbase, front_overhang, wheel_radius, style):
    """Return (polygon, windscreen_top): polygon a list of [x, z] points (m), closed
    implicitly, clockwise (x right, z up) from the rear bumper's lower corner."""
    front_axle = length - front_overhang
    rear_axle = front_axle - wheelbase
    sill = 0.42 * wheel_radius + 0.05  # ground clearance of the rocker panel
    bonnet_front = 0.70 + 0.05 * (height - 1.43)
    windscreen_base_x = front_axle - 0.55
    windscreen_base_z = bonnet_front + 0.20
    windscreen_top_x = windscreen_base_x - 0.80 * (height - windscreen_base_z) / 0.49
    if style == "sedan":
        roof_rear_x = rear_axle + 0.45
        deck_x, deck_z = 0.45, 1.00
        tail_top = (0.03, 0.97)
    else:  # hatchback: the roof runs further back and the tailgate is steep
        roof_rear_x = rear_axle + 0.05
        deck_x, deck_z = 0.08, 1.05
        tail_top = (0.02, 0.95)
    pts = [
        [0.05, sill + 0.12],                        # rear bumper, lower corner
        [0.00, 0.55],                               # rear bumper face
        list(tail_top),
        [deck_x, deck_z],                           # boot lid / tailgate
        [roof_rear_x - 0.10, height - 0.04],        # C-pillar top
        [roof_rear_x + 0.15, height],               # roof, rear end
        [windscreen_top_x, height - 0.01],          # roof edge at the top of the windscreen
        [windscreen_base_x, windscreen_base_z],     # windscreen base
        [length - 0.15, bonnet_front + 0.04],       # bonnet front
        [length - 0.02, bonnet_front - 0.12],       # grille top
        [length, 0.45],                             # front bumper face
        [length - 0.06, sill + 0.10],               # front bumper, lower corner
        [front_axle + 1.05 * wheel_radius, sill],   # front wheel arch, front
        [front_axle + 0.90 * wheel_radius, wheel_radius + 0.10],
        [front_axle, 1.25 * wheel_radius + 0.06],   # front wheel arch, top
        [front_axle - 0.90 * wheel_radius, wheel_radius + 0.10],
        [front_axle - 1.05 * wheel_radius, sill],
        [rear_axle + 1.05 * wheel_radius, sill],    # sill
        [rear_axle + 0.90 * wheel_radius, wheel_radius + 0.10],
        [rear_axle, 1.25 * wheel_radius + 0.06],    # rear wheel arch, top
        [rear_axle - 0.90 * wheel_radius, wheel_radius + 0.10],
        [rear_axle - 1.05 * wheel_radius, sill],
    ]
    pts = [[round(x, 3), round(z, 3)] for x, z in pts]
    return pts, [round(windscreen_top_x, 3), round(height - 0.01, 3)]


def main() -> int:
    for name, dims in CARS.items():
        poly, top = outline(*dims)
        print(f"# {name}")
        print("silhouette_side = [" + ", ".join(f"[{x}, {z}]" for x, z in poly) + "]")
        print(f"windscreen_top = [{top[0]}, {top[1]}]")
    return 0


if __name__ == "__main__":
    sys.exit(main())

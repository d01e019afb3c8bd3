"""`patchlight volume SCENE_OR_BAKE_DIR -o DIR`: a light volume of ambient cubes.

Each probe of a regular grid stores the incident light from six directions (+X, +Y, +Z, -X,
-Y, -Z), gathered from the solved radiosity of a bake directory (or of the scene, baked
first), the sky, and the lights through shadow rays. Writes DIR/light_volume.json (header,
format in patchlight.volumes.io), DIR/light_volume.bin (data) and DIR/volume.json (stats)."""
from __future__ import annotations

from pathlib import Path

from ..volumes.grid import GridSettings
from ..volumes.probes import VolumeSettings
from .options import about, add_scene_options, load_solved_from_args
from .parser import finite_number, writes_output
from .values import parse_bounds, parse_dims

STATS = "volume.json"


def register(sub) -> None:
    p = sub.add_parser("volume", help="bake a light volume of ambient cubes", description=__doc__)
    p.add_argument("scene", metavar="SCENE_OR_BAKE_DIR",
                   help="a bake directory, a .glb/.gltf file or a built-in scene (room, cornell)")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="DIR")
    size = p.add_mutually_exclusive_group()
    size.add_argument("--spacing", type=finite_number, metavar="M", help=about("spacing", GridSettings))
    size.add_argument("--dims", metavar="NX,NY,NZ", help=about("dims", GridSettings))
    p.add_argument("--bounds", metavar="X0,Y0,Z0,X1,Y1,Z1", help=about("bounds", GridSettings))
    p.add_argument("--rays", type=int, default=VolumeSettings.rays, metavar="N", help=about("rays", VolumeSettings))
    p.add_argument("--compact", action="store_true", help="store one colour and six intensities per probe")
    p.add_argument("--seed", type=int, default=VolumeSettings.seed, help=about("seed", VolumeSettings))
    add_scene_options(p, VolumeSettings)
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--json", action="store_true", help="print volume.json on stdout")
    p.set_defaults(func=writes_output(run))


def grid_settings(args) -> GridSettings:
    return GridSettings(spacing=args.spacing, dims=parse_dims(args.dims) if args.dims else None,
                        bounds=parse_bounds(args.bounds) if args.bounds else None)


def run(args) -> int:
    from ..imaging.io import check_output_dir, json_text, write_json
    from ..inputs import open_input
    from ..outputs import staged_output
    from ..volumes import bake_volume, write_volume
    from ..volumes.io import DATA, HEADER

    settings = VolumeSettings(rays=args.rays, sun_angle=args.sun_angle, falloff=args.falloff, seed=args.seed)
    where = grid_settings(args)
    where.validate()
    check_output_dir(args.output)
    quiet = args.quiet or args.json
    source = open_input(args.scene)
    if source.kind in ("builtin", "scene"):  # a scene to bake first: refuse a bad grid before the bake
        where.grid(*source.scene().bounds())
    solved = load_solved_from_args(args, quiet)
    grid = where.grid(*solved.scene.bounds())
    volume, stats = bake_volume(solved, grid, settings, quiet=quiet)
    stats["layout"] = "compact" if args.compact else "full"
    stats["files"] = [DATA, HEADER, STATS]
    with staged_output(args.output) as staging:
        write_json(staging / STATS, stats)
        write_volume(staging, volume, stats["layout"])
    if args.json:
        print(json_text(stats, "volume statistics"))
    elif not args.quiet:
        nx, ny, nz = grid.dims
        print(f"baked {grid.count} probes ({nx} x {ny} x {nz}, {stats['inside_geometry_probes']} inside geometry) "
              f"in {stats['seconds']:.1f} s: {stats['probes_per_second']:.0f} probes/s, "
              f"{stats['rays_per_second'] / 1e6:.2f} Mrays/s")
        print(f"results in {args.output}/: {DATA} {HEADER} {STATS}")
    return 0

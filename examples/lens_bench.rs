//! Lens bench: a lens prescription from `assets/lenses/`, drawn in section with
//! a fan of real rays and the brightest flare ghost traced through it by
//! `optica::optics` — the CPU reference every plugin is tested against.
//!
//! ```sh
//! cargo run --features window --example lens_bench -- [--lens tessar|double-gauss|heliar|FILE.lens]
//!     [--field DEG] [--ghost I,J] [--out FILE.png]
//! ```
//!
//! With the `window` feature and a display it opens a window; otherwise (or
//! with `--out`) it renders headlessly on lavapipe and writes a PNG, by default
//! `target/optica/lens_bench.png`.
//!
//! Green: the primary path of a ray fan from a distant point `--field` degrees
//! off axis. Orange: the same fan along the ghost path (i, j) — reflected at
//! surface i, then at surface j — which by default is the brightest ghost by
//! `lens_flare::estimate_ghosts`. Red: rays that miss a surface, are totally
//! internally reflected (drawn as far as they got) or pass outside a
//! semi-aperture or the stop (vignetted).

use bevy::{asset::RenderAssetUsages, camera::ScalingMode, mesh::PrimitiveTopology, prelude::*};
use optica::optics::{
    glam::DVec3,
    glass::{Glass, LAMBDA_D_NM},
    lens::{LensPrescription, PreparedLens, TracePath, builtin},
    lens_flare::{Aperture, EstimateOptions, estimate_ghosts, light_from_field},
    ray::Ray,
    surface::SphericalSurface,
};

const WIDTH: u32 = 960;
const HEIGHT: u32 = 540;
const FAN_RAYS: usize = 13;

struct Args {
    lens: LensPrescription,
    field_deg: f64,
    ghost: Option<(usize, usize)>,
    out: Option<String>,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args().skip(1);
    let (mut lens, mut field_deg, mut ghost, mut out) = (builtin::tessar(), 8.0, None, None);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--lens" => {
                lens = match value()?.as_str() {
                    "tessar" => builtin::tessar(),
                    "double-gauss" => builtin::double_gauss(),
                    "heliar" => builtin::heliar(),
                    path => LensPrescription::load(path).map_err(|e| e.to_string())?,
                }
            }
            "--field" => {
                field_deg = value()?
                    .parse()
                    .map_err(|_| "--field takes degrees".to_string())?;
                if !(0.0..60.0).contains(&field_deg) {
                    return Err("--field must be in [0, 60) degrees".into());
                }
            }
            "--ghost" => {
                let v = value()?;
                let (i, j) = v.split_once(',').ok_or("--ghost takes I,J")?;
                ghost = Some((
                    i.trim().parse().map_err(|_| "bad I")?,
                    j.trim().parse().map_err(|_| "bad J")?,
                ));
            }
            "--out" => out = Some(value()?),
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    Ok(Args {
        lens,
        field_deg,
        ghost,
        out,
    })
}

fn main() {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("lens_bench: {e}");
            std::process::exit(2);
        }
    };
    let drawing = match LensDrawing::new(&args) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("lens_bench: {e}");
            std::process::exit(1);
        }
    };
    println!("{}", drawing.caption);
    let has_display = std::env::var_os("DISPLAY").is_some();
    if cfg!(feature = "window") && has_display && args.out.is_none() {
        App::new()
            .add_plugins(DefaultPlugins.set(WindowPlugin {
                primary_window: Some(Window {
                    title: format!("optica lens bench — {}", drawing.caption),
                    resolution: (WIDTH, HEIGHT).into(),
                    ..default()
                }),
                ..default()
            }))
            .insert_resource(drawing)
            .add_systems(Startup, spawn_scene)
            .run();
    } else {
        let out = args
            .out
            .unwrap_or_else(|| "target/optica/lens_bench.png".into());
        let frame = optica_harness::Headless::new(WIDTH, HEIGHT)
            .adapter(optica_harness::Adapter::Auto)
            .render(|app| {
                app.insert_resource(drawing)
                    .add_systems(Startup, spawn_scene);
            })
            .unwrap_or_else(|e| {
                eprintln!("lens_bench: headless render failed: {e}");
                std::process::exit(1);
            });
        if let Some(dir) = std::path::Path::new(&out).parent() {
            let _ = std::fs::create_dir_all(dir);
        }
        frame.to_rgba8().save(&out).unwrap_or_else(|e| {
            eprintln!("lens_bench: cannot write {out}: {e}");
            std::process::exit(1);
        });
        println!("rendered on {} -> {out}", frame.adapter);
    }
}

/// Line segments (in mm, lens z along screen x) by colour.
#[derive(Resource)]
struct LensDrawing {
    caption: String,
    glass: Vec<[Vec2; 2]>,
    axis: Vec<[Vec2; 2]>,
    primary: Vec<[Vec2; 2]>,
    ghost: Vec<[Vec2; 2]>,
    failed: Vec<[Vec2; 2]>,
    centre: Vec2,
    half_extent: Vec2,
}

impl LensDrawing {
    fn new(args: &Args) -> Result<Self, String> {
        let lens = &args.lens;
        let prepared = PreparedLens::new(lens, LAMBDA_D_NM).map_err(|e| e.to_string())?;
        let vz = lens.vertex_z();
        let sensor_z = prepared.table_sensor_z();
        let light = light_from_field(args.field_deg, 90.0);
        let ghost = match args.ghost {
            Some((i, j)) => TracePath::ghost(i, j),
            None => estimate_ghosts(
                lens,
                light,
                LAMBDA_D_NM,
                &Aperture::of_stop(lens),
                &EstimateOptions::default(),
            )
            .map_err(|e| e.to_string())?
            .first()
            .map(|g| g.path)
            .ok_or("the lens has no ghost")?,
        };
        prepared
            .check_path(ghost)
            .map_err(|e| format!("ghost path: {e}"))?;

        let mut d = LensDrawing {
            caption: format!(
                "{} — field {}°, ghost {:?}",
                lens.name(),
                args.field_deg,
                ghost
            ),
            glass: Vec::new(),
            axis: Vec::new(),
            primary: Vec::new(),
            ghost: Vec::new(),
            failed: Vec::new(),
            centre: Vec2::ZERO,
            half_extent: Vec2::ONE,
        };
        // Surface profiles, element rims and the stop.
        let profile = |k: usize| -> Vec<Vec2> {
            let s = &lens.surfaces()[k];
            // A validated prescription has finite vertices and curvatures.
            let Ok(geometry) = SphericalSurface::new(vz[k], s.curvature) else {
                return Vec::new();
            };
            let a = s.semi_aperture_mm;
            (0..=32)
                .filter_map(|i| {
                    let y = -a + 2.0 * a * i as f64 / 32.0;
                    geometry
                        .sag(y.abs())
                        .map(|sag| Vec2::new((vz[k] + sag) as f32, y as f32))
                })
                .collect()
        };
        for (k, s) in lens.surfaces().iter().enumerate() {
            if s.is_stop {
                let (a, z) = (s.semi_aperture_mm as f32, vz[k] as f32);
                d.glass.push([Vec2::new(z, a), Vec2::new(z, a * 1.4)]);
                d.glass.push([Vec2::new(z, -a), Vec2::new(z, -a * 1.4)]);
                continue;
            }
            let p = profile(k);
            d.glass.extend(p.windows(2).map(|w| [w[0], w[1]]));
            let inside_glass =
                !matches!(s.glass_after, Glass::Air) && k + 1 < lens.surfaces().len();
            if inside_glass {
                let q = profile(k + 1);
                if let (Some(p0), Some(q0), Some(p1), Some(q1)) =
                    (p.first(), q.first(), p.last(), q.last())
                {
                    d.glass.push([*p0, *q0]);
                    d.glass.push([*p1, *q1]);
                }
            }
        }
        let last = *vz.last().unwrap_or(&0.0) as f32;
        let rim = lens
            .surfaces()
            .iter()
            .map(|s| s.semi_aperture_mm)
            .fold(0.0, f64::max) as f32;
        let start_z = -0.35 * (sensor_z as f32).max(rim);
        d.axis
            .push([Vec2::new(start_z, 0.0), Vec2::new(sensor_z as f32, 0.0)]);
        d.axis.push([
            Vec2::new(sensor_z as f32, -rim),
            Vec2::new(sensor_z as f32, rim),
        ]);

        // A fan in the y–z plane, aimed at the entrance pupil's centre region.
        let pupil = lens.paraxial(LAMBDA_D_NM).map_err(|e| e.to_string())?;
        let reach = pupil.entrance_pupil_radius_mm;
        for i in 0..FAN_RAYS {
            let h = -reach + 2.0 * reach * i as f64 / (FAN_RAYS - 1) as f64;
            let aim = DVec3::new(0.0, h, pupil.entrance_pupil_z_mm);
            let origin = aim - light * (aim.z - start_z as f64) / light.z;
            let ray = Ray::new(origin, light).map_err(|e| e.to_string())?;
            for (path, lines) in [(TracePath::Primary, 0), (ghost, 1)] {
                let (points, result) = prepared.trace_polyline(ray, path, sensor_z);
                let target = match (&result, lines) {
                    // Missed, totally reflected, or outside a semi-aperture (vignetted).
                    (Err(_), _) => &mut d.failed,
                    (Ok(r), _) if r.r_rel > 1.0 => &mut d.failed,
                    (Ok(_), 0) => &mut d.primary,
                    _ => &mut d.ghost,
                };
                let pts: Vec<Vec2> = points
                    .iter()
                    .map(|p| Vec2::new(p.z as f32, p.y as f32))
                    .collect();
                target.extend(pts.windows(2).map(|w| [w[0], w[1]]));
            }
        }
        let min = Vec2::new(start_z, -rim * 1.5);
        let max = Vec2::new((sensor_z as f32).max(last) + 5.0, rim * 1.5);
        d.centre = (min + max) / 2.0;
        d.half_extent = (max - min) / 2.0;
        Ok(d)
    }
}

fn line_mesh(segments: &[[Vec2; 2]]) -> Mesh {
    let positions: Vec<[f32; 3]> = segments
        .iter()
        .flat_map(|s| s.iter().map(|p| [p.x, p.y, 0.0]))
        .collect();
    Mesh::new(PrimitiveTopology::LineList, RenderAssetUsages::RENDER_WORLD)
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
}

fn spawn_scene(
    mut commands: Commands,
    drawing: Res<LensDrawing>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let layers: [(&[[Vec2; 2]], Color, f32); 5] = [
        (&drawing.axis, Color::srgb(0.35, 0.38, 0.45), 0.0),
        (&drawing.glass, Color::srgb(0.55, 0.8, 1.0), 0.1),
        (&drawing.failed, Color::srgb(0.7, 0.15, 0.15), 0.2),
        (&drawing.primary, Color::srgb(0.3, 0.95, 0.45), 0.3),
        (&drawing.ghost, Color::srgb(1.0, 0.6, 0.15), 0.4),
    ];
    for (segments, color, z) in layers {
        if segments.is_empty() {
            continue;
        }
        commands.spawn((
            Mesh3d(meshes.add(line_mesh(segments))),
            MeshMaterial3d(materials.add(StandardMaterial {
                base_color: color,
                unlit: true,
                ..default()
            })),
            Transform::from_xyz(0.0, 0.0, z),
        ));
    }
    // Fit the drawing into the 16:9 frame.
    let aspect = WIDTH as f32 / HEIGHT as f32;
    let half_height = drawing.half_extent.y.max(drawing.half_extent.x / aspect) * 1.05;
    commands.spawn((
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::srgb(0.04, 0.05, 0.08)),
            ..default()
        },
        Projection::from(OrthographicProjection {
            scaling_mode: ScalingMode::FixedVertical {
                viewport_height: 2.0 * half_height,
            },
            ..OrthographicProjection::default_3d()
        }),
        Transform::from_xyz(drawing.centre.x, drawing.centre.y, 100.0)
            .looking_at(drawing.centre.extend(0.0), Vec3::Y),
    ));
}

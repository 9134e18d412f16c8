//! Bodies from Gmsh meshes (`shape = "mesh"`): a particle per cell at its centroid with the
//! cell's area as its volume, checked against the mesh's own area and the weight a support
//! holds; and a particle per vertex with the quadrangles as the Galerkin cells
//! (`nodes = "vertices"`), checked against the lattice's FEM bar.

use crate::common::cpu_options;
use meshless::core::tensor::D2;
use meshless::output::series::read_column;
use meshless::reference::Reference;
use meshless::run::run;
use meshless::scene::Scene;

/// The box [0, L] × [0, H] as an nx × ny grid whose interior nodes are moved by up to a
/// quarter of a cell in each direction (a fixed pseudo-random pattern), each quadrangle
/// split into two triangles: Gmsh's ASCII format 4.1, with the boundary lines a mesher
/// writes besides the cells (which the reader skips).
fn irregular_box(l: f64, h: f64, nx: usize, ny: usize) -> String {
    let (dx, dy) = (l / nx as f64, h / ny as f64);
    let mut seed = 12345u64;
    let mut jitter = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.5
    };
    let node = |i: usize, j: usize| (j * (nx + 1) + i + 1) as u64;
    let mut coordinates = String::new();
    for j in 0..=ny {
        for i in 0..=nx {
            let interior = i > 0 && i < nx && j > 0 && j < ny;
            let (ex, ey) = if interior {
                (jitter(), jitter())
            } else {
                (0.0, 0.0)
            };
            let (x, y) = ((i as f64 + ex) * dx, (j as f64 + ey) * dy);
            coordinates.push_str(&format!("{x} {y} 0\n"));
        }
    }
    let nodes = (nx + 1) * (ny + 1);
    let tags: String = (1..=nodes).map(|t| format!("{t}\n")).collect();
    let mut triangles = String::new();
    let mut tag = 2;
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (
                node(i, j),
                node(i + 1, j),
                node(i + 1, j + 1),
                node(i, j + 1),
            );
            triangles.push_str(&format!("{tag} {a} {b} {c}\n{} {a} {c} {d}\n", tag + 1));
            tag += 2;
        }
    }
    let cells = 2 * nx * ny;
    format!(
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 {nodes} 1 {nodes}\n2 1 0 {nodes}\n\
         {tags}{coordinates}$EndNodes\n$Elements\n2 {} 1 {}\n1 1 1 1\n1 1 2\n2 1 2 {cells}\n\
         {triangles}$EndElements\n",
        cells + 1,
        cells + 1
    )
}

#[test]
fn a_meshed_block_has_the_mesh_area_and_its_support_holds_its_weight() {
    // A 0.1 × 0.02 m block meshed by 20 × 4 distorted quadrangles split into 160
    // triangles, resting on the cells with an edge on y = 0 (centroids at y = Δy/3 ± 0.42
    // mm, below the region's 1 mm + Δx/4; the other cells of the bottom row lie above
    // 2.5 mm), under gravity, solved statically with
    // TLSPH (Randles–Libersky, h = 1.3 × 5 mm). The volumes are the triangles' areas, so
    // they sum to the box's 2e-3 m² to round-off, and at equilibrium the support holds
    // the weight ρ g Σ V to the Newton tolerance (relative 1e-8 of the load).
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("block.msh"),
        irregular_box(0.1, 0.02, 20, 4),
    )
    .unwrap();
    let text = r#"
name = "meshed-block"
dimension = 2
spacing = 0.005
[material]
model = "linear-elastic"
density = 1000.0
youngs_modulus = 1.0e6
poisson_ratio = 0.3
[method]
name = "tlsph"
h_over_dx = 1.3
force = "variational"
dt = 1.0
[[body]]
name = "block"
geometry = { shape = "mesh", file = "block.msh" }
[[boundary]]
name = "floor"
region = { y_max = 0.001 }
condition = { type = "fixed" }
[[boundary]]
region = {}
condition = { type = "body-force", acceleration = [0.0, -9.81] }
[run]
end_time = 1.0
solve = "static"
[output]
observers = ["reaction"]
"#;
    let case = Scene::from_toml(text, &dir.path().join("meshed-block.toml"), &[]).unwrap();
    let reference = Reference::<D2>::build(&case).unwrap();
    assert_eq!(reference.x0.len(), 160);
    let area: f64 = reference.vol.iter().sum();
    assert!((area - 2e-3).abs() < 1e-17, "Σ V = {area:e}");
    let held = reference.boundary.constrained.len();
    assert_eq!(held, 20, "the bottom row's triangles with an edge on y = 0");

    let out = tempfile::tempdir().unwrap();
    run(&case, &cpu_options(out.path(), false)).unwrap();
    let reaction = read_column(&out.path().join("series.csv"), "floor.reaction_y").unwrap();
    let weight = 1000.0 * 9.81 * area;
    let r = reaction.last().unwrap().1;
    assert!(
        (r - weight).abs() < 1e-8 * weight,
        "R_y = {r} against the weight {weight}"
    );
}

#[test]
fn a_mesh_file_that_is_not_one_is_named_with_its_key() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.msh"), "x,y\n0,0\n").unwrap();
    let text = r#"
name = "bad-mesh"
dimension = 2
spacing = 0.005
[material]
model = "linear-elastic"
density = 1000.0
youngs_modulus = 1.0e6
poisson_ratio = 0.3
[method]
name = "tlsph"
h_over_dx = 1.3
dt = 1.0e-6
[[body]]
name = "block"
geometry = { shape = "mesh", file = "bad.msh" }
[run]
end_time = 1.0e-5
"#;
    let case = Scene::from_toml(text, &dir.path().join("bad.toml"), &[]).unwrap();
    let err = Reference::<D2>::build(&case).err().unwrap().to_string();
    for part in ["body.0.geometry.file", "bad.msh", "$MeshFormat"] {
        assert!(err.contains(part), "{err}");
    }
}

/// The box [0, L] × [0, H] as a structured nx × ny grid of quadrangles (counter-clockwise
/// corners), Gmsh's ASCII format 2.2, with the nodes numbered from the top row down so
/// that the particles' order differs from a lattice's. The interior nodes are moved
/// along x by `skew` cell widths times sin(π y/H), so that with `skew` > 0 no cell is a
/// rectangle (the faces stay straight).
fn structured_quads(l: f64, h: f64, nx: usize, ny: usize, skew: f64) -> String {
    let (dx, dy) = (l / nx as f64, h / ny as f64);
    let node = |i: usize, j: usize| ((ny - j) * (nx + 1) + i + 1) as u64;
    let mut nodes = String::new();
    for j in (0..=ny).rev() {
        for i in 0..=nx {
            let y = j as f64 * dy;
            let interior = i > 0 && i < nx && j > 0 && j < ny;
            let shift = if interior {
                skew * dx * (std::f64::consts::PI * y / h).sin()
            } else {
                0.0
            };
            nodes.push_str(&format!("{} {} {y} 0\n", node(i, j), i as f64 * dx + shift));
        }
    }
    let mut quads = String::new();
    let mut tag = 1;
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (
                node(i, j),
                node(i + 1, j),
                node(i + 1, j + 1),
                node(i, j + 1),
            );
            quads.push_str(&format!("{tag} 3 2 0 1 {a} {b} {c} {d}\n"));
            tag += 1;
        }
    }
    format!(
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n{}\n{nodes}$EndNodes\n$Elements\n{}\n\
         {quads}$EndElements\n",
        (nx + 1) * (ny + 1),
        nx * ny
    )
}

/// A static plane-stress linear-elastic `tl-fem` bar 4 × 1 m at Δx = 0.125 m with `geometry`,
/// on rollers at x = 0 and pulled by t = 1e4 Pa at x = 4 (the region's y bounds clip the
/// face, as a mesh has no named extent); the mean u_x of the loaded end.
fn pulled_fem_bar(dir: &std::path::Path, geometry: &str) -> f64 {
    let text = format!(
        r#"
name = "bar"
dimension = 2
spacing = 0.125
[material]
model = "linear-elastic"
plane = "stress"
density = 1000.0
youngs_modulus = 1.0e7
poisson_ratio = 0.3
[method]
name = "tl-fem"
dt = 1.0
[[body]]
name = "bar"
geometry = {geometry}
[[boundary]]
region = {{ x_max = 0.0 }}
condition = {{ type = "velocity", vx = 0.0 }}
[[boundary]]
region = {{ x_max = 0.0, y_max = 0.0 }}
condition = {{ type = "velocity", vy = 0.0 }}
[[boundary]]
region = {{ x_min = 4.0, y_min = 0.0, y_max = 1.0 }}
condition = {{ type = "traction", traction = [1.0e4, 0.0] }}
[run]
solve = "static"
end_time = 1.0
"#
    );
    let case = Scene::from_toml(&text, &dir.join("bar.toml"), &[]).unwrap();
    let mut e = meshless::run::engine::<D2>(&case, meshless::run::Backend::Cpu).unwrap();
    e.advance(0.0, 1.0, 1).unwrap_or_else(|f| panic!("{f:?}"));
    let s = e.snapshot();
    let end: Vec<usize> = (0..s.x0.len())
        .filter(|&i| (s.x0[i].x - 4.0).abs() < 1e-9)
        .collect();
    assert_eq!(end.len(), 9);
    end.iter().map(|&i| s.u[i].x).sum::<f64>() / end.len() as f64
}

#[test]
fn a_quad_mesh_at_its_vertices_is_the_fem_bar_of_the_lattice() {
    // The mesh's 32 × 8 quadrangles are the lattice's cells with the nodes numbered
    // otherwise: the extension is the lattice bar's to the round-off of a reordered
    // sparse solve (1e-10), and tL/E (4e-3 m) as the FEM's patch test gives it (the
    // verification matrix's bound, 1e-9; measured 1e-10).
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("bar.msh"),
        structured_quads(4.0, 1.0, 32, 8, 0.0),
    )
    .unwrap();
    let mesh = pulled_fem_bar(
        dir.path(),
        "{ shape = \"mesh\", file = \"bar.msh\", nodes = \"vertices\" }",
    );
    let lattice = pulled_fem_bar(
        dir.path(),
        "{ shape = \"box\", min = [0.0, 0.0], max = [4.0, 1.0] }",
    );
    let exact = 1.0e4 * 4.0 / 1.0e7;
    eprintln!("end u_x: mesh {mesh:.15e}, lattice {lattice:.15e}, tL/E {exact:e}");
    assert!(
        (mesh / lattice - 1.0).abs() < 1e-10,
        "{mesh} against {lattice}"
    );
    assert!((mesh / exact - 1.0).abs() < 1e-9, "{mesh} against {exact}");
    // The vertices' volumes are the quarter shares of their cells: they sum to the mesh's
    // 4 m² (to round-off), and the mesh's cells are the body's.
    let case = Scene::from_toml(
        "name = \"bar\"\ndimension = 2\nspacing = 0.125\n[material]\nmodel = \
         \"linear-elastic\"\ndensity = 1000.0\nyoungs_modulus = 1e7\npoisson_ratio = 0.3\n\
         [method]\nname = \"tl-fem\"\ndt = 1e-5\n[[body]]\nname = \"bar\"\ngeometry = { \
         shape = \"mesh\", file = \"bar.msh\", nodes = \"vertices\" }\n[run]\nend_time = \
         1e-4\n",
        &dir.path().join("bar.toml"),
        &[],
    )
    .unwrap();
    let r = Reference::<D2>::build(&case).unwrap();
    let total: f64 = r.vol.iter().sum();
    assert!((total - 4.0).abs() < 1e-13, "{total}");
    assert_eq!(r.cells(0.125).unwrap().len(), 32 * 8);
}

#[test]
fn mesh_vertices_are_refused_for_particle_methods_and_triangles() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tri.msh"), irregular_box(1.0, 1.0, 4, 4)).unwrap();
    let case = |method: &str, keys: &str| {
        Scene::from_toml(
            &format!(
                "name = \"m\"\ndimension = 2\nspacing = 0.25\n[material]\nmodel = \
                 \"linear-elastic\"\ndensity = 1000.0\nyoungs_modulus = 1e7\npoisson_ratio = \
                 0.3\n[method]\nname = \"{method}\"\n{keys}\ndt = 1e-5\n[[body]]\nname = \
                 \"b\"\ngeometry = {{ shape = \"mesh\", file = \"tri.msh\", nodes = \
                 \"vertices\" }}\n[run]\nend_time = 1e-4\n"
            ),
            &dir.path().join("m.toml"),
            &[],
        )
    };
    let e = case("tlsph", "h_over_dx = 1.3").unwrap_err().to_string();
    assert!(
        e.contains("key `body.0.geometry.nodes`") && e.contains("`tlsph`"),
        "{e}"
    );
    let c = case("tl-fem", "").unwrap();
    let e = Reference::<D2>::build(&c).err().unwrap().to_string();
    assert!(
        e.contains("key `body.0.geometry.file`") && e.contains("is a triangle"),
        "{e}"
    );
}

#[cfg(feature = "gpu")]
#[test]
fn the_gpu_runs_a_skewed_quad_mesh_at_its_vertices_as_the_cpu() {
    // Every method with a GPU engine that integrates over cells (`ul-fem` on the current
    // cells), on a mesh whose cells are no lattice's (interior nodes moved by up to 0.3 of
    // a cell), clamped at x = 0 and
    // released with v_y = 0.05 x m/s, 40 steps of 1e-4 s (c Δt/Δx = 0.08): the GPU's
    // displacements against the CPU's within 1e-5 of the largest, f32 rounding (6e-8)
    // over 40 steps of four RK4 stages, each summing the forces of about 30 nodes
    // (measured 8e-7). The skew makes the mesh's cells matter: the lattice's cells would give
    // other shape functions and quadrature points.
    use meshless::methods::REGISTRY;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("skew.msh"),
        structured_quads(2.0, 0.5, 16, 4, 0.3),
    )
    .unwrap();
    let _adapter = crate::common::gpu();
    let mut checked = Vec::new();
    for entry in REGISTRY {
        let text = format!(
            r#"
name = "skew"
dimension = 2
spacing = 0.125
[material]
model = "saint-venant-kirchhoff"
plane = "stress"
density = 1000.0
youngs_modulus = 1.0e7
poisson_ratio = 0.3
[method]
name = "{}"
{}
dt = 1.0e-4
[[body]]
name = "plate"
geometry = {{ shape = "mesh", file = "skew.msh", nodes = "vertices" }}
initial_velocity = {{ type = "expression", vx = "0", vy = "0.05*x" }}
[[boundary]]
region = {{ x_max = 0.0 }}
condition = {{ type = "fixed" }}
[run]
end_time = 4.0e-3
"#,
            entry.name,
            if entry.kernel { "h_over_dx = 1.3" } else { "" }
        );
        // The methods that integrate at their particles refuse the vertices, and the
        // Jaumann-rate ones this model.
        let case = match Scene::from_toml(&text, &dir.path().join("skew.toml"), &[]) {
            Ok(case) => case,
            Err(e) => {
                eprintln!("{}: {e}", entry.name);
                continue;
            }
        };
        let run = |backend| {
            let mut e = meshless::run::engine::<D2>(&case, backend)
                .unwrap_or_else(|e| panic!("{}: {e}", entry.name));
            e.advance(0.0, 1.0e-4, 40)
                .unwrap_or_else(|f| panic!("{}: {f:?}", entry.name));
            e.snapshot().u.to_vec()
        };
        let (cpu, gpu) = (
            run(meshless::run::Backend::Cpu),
            run(meshless::run::Backend::Gpu),
        );
        let (diff, largest) = crate::common::max_v::<D2>(&gpu, &cpu);
        eprintln!(
            "{}: |u_GPU − u_CPU| {diff:.2e} of {largest:.2e} m",
            entry.name
        );
        assert!(
            diff < 1e-5 * largest,
            "{}: {diff:e} of {largest:e} m",
            entry.name
        );
        checked.push(entry.name);
    }
    assert_eq!(checked, ["tl-weak-form", "tl-fem", "ul-fem", "kbm", "efg"]);
}

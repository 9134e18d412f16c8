use super::{check, minimal_case};
use crate::case::{
    Axis, BoundarySpec, Condition, Lattice, Observer, ProbeSpec, Region, RingLattice, Shape,
    TimeLaw, VelocityField,
};
use crate::scene::Scene;

fn key_of(case: &Scene) -> String {
    check(case).unwrap_err().0
}

#[test]
fn valid_case_passes() {
    let c = minimal_case();
    assert_eq!(c.method.name, "tlsph");
    check(&c).unwrap();
}

#[test]
fn first_problem_in_order_is_reported() {
    let mut c = minimal_case();
    c.dimension = 4;
    c.material.poisson_ratio = Some(0.5);
    assert_eq!(key_of(&c), "dimension");
    c.dimension = 2;
    assert_eq!(key_of(&c), "material.poisson_ratio");
    let (_, msg) = check(&c).unwrap_err();
    assert!(msg.contains("(−1, 0.5)") && msg.contains("0.5"), "{msg}");
}

#[test]
fn names_and_numbers() {
    let mut c = minimal_case();
    c.name = "a b".into();
    assert_eq!(key_of(&c), "name");
    c.name = "a-b_1".into();
    c.spacing = f64::NAN;
    assert_eq!(key_of(&c), "spacing");
    c.spacing = 0.1;
    c.method.h_over_dx = 5.0;
    assert_eq!(key_of(&c), "method.h_over_dx");
    c.method.h_over_dx = 1.3;
    c.method.dt = None;
    c.method.cfl = Some(2.5);
    assert_eq!(key_of(&c), "method.cfl");
    c.method.cfl = Some(2.0);
    check(&c).unwrap();
}

/// A ring about the origin of outer radius 1.
fn unit_ring(inner_radius: f64, lattice: RingLattice, sectors: Option<u32>) -> Shape {
    Shape::Ring {
        center: vec![0.0, 0.0],
        inner_radius,
        outer_radius: 1.0,
        lattice,
        sectors,
        volumes: None,
    }
}

/// A cylinder of unit radius and length along z, at the origin.
fn unit_cylinder(inner_radius: f64) -> Shape {
    Shape::Cylinder {
        base: vec![0.0, 0.0, 0.0],
        axis: Axis::Z,
        radius: 1.0,
        inner_radius,
        length: 1.0,
        lattice: Lattice::Vertex,
        volumes: None,
    }
}

#[test]
fn bodies_and_shapes() {
    let mut c = minimal_case();
    let body = c.bodies[0].clone();
    c.bodies.push(body);
    assert_eq!(key_of(&c), "body.1.name");
    c.bodies[1].name = "c".into();
    c.bodies[1].geometry = unit_ring(1.0, RingLattice::Square, None);
    assert_eq!(key_of(&c), "body.1.geometry.inner_radius");
    c.bodies[1].geometry = unit_ring(0.5, RingLattice::Square, Some(60));
    assert_eq!(key_of(&c), "body.1.geometry.sectors");
    c.bodies[1].geometry = unit_ring(0.5, RingLattice::Polar, Some(2));
    assert_eq!(key_of(&c), "body.1.geometry.sectors");
    c.bodies[1].geometry = unit_ring(0.0, RingLattice::Polar, None);
    assert_eq!(key_of(&c), "body.1.geometry.inner_radius");
    c.bodies[1].geometry = unit_cylinder(0.0);
    let (key, msg) = check(&c).unwrap_err();
    assert_eq!(key, "body.1.geometry.shape");
    assert!(msg.contains("only in 3D"), "{msg}");
    c.bodies[1].geometry = Shape::Box {
        min: vec![0.0, 1.0],
        max: vec![1.0, 1.0],
        volumes: None,
        lattice: Default::default(),
    };
    assert_eq!(key_of(&c), "body.1.geometry.max");
    c.bodies[1].geometry = Shape::Points { file: "".into() };
    assert_eq!(key_of(&c), "body.1.geometry.file");
    c.bodies.pop();
    c.bodies[0].initial_velocity = Some(VelocityField::RigidRotation {
        omega: 1.0,
        center: vec![0.0, 0.0],
        axis: Some(vec![0.0, 0.0, 1.0]),
    });
    assert_eq!(key_of(&c), "body.0.initial_velocity.axis");
    c.bodies[0].initial_velocity = Some(VelocityField::GaussianPulse {
        amplitude: 1.0,
        direction: vec![0.0, 0.0],
        center: 0.0,
        width: 1.0,
    });
    assert_eq!(key_of(&c), "body.0.initial_velocity.direction");
    c.bodies.clear();
    assert_eq!(key_of(&c), "body");
}

#[test]
fn three_d_requirements() {
    let mut c = minimal_case();
    c.dimension = 3;
    assert_eq!(key_of(&c), "body.0.geometry.min");
    c.bodies[0].geometry = unit_cylinder(0.5);
    check(&c).unwrap();
    c.bodies[0].initial_velocity = Some(VelocityField::RigidRotation {
        omega: 1.0,
        center: vec![0.0, 0.0, 0.0],
        axis: None,
    });
    assert_eq!(key_of(&c), "body.0.initial_velocity.axis");
}

#[test]
fn boundaries_run_output_probes() {
    let mut c = minimal_case();
    c.boundaries.push(BoundarySpec {
        name: None,
        region: Region {
            body: Some("nope".into()),
            ..Region::default()
        },
        condition: Condition::Fixed {},
    });
    let (key, msg) = check(&c).unwrap_err();
    assert_eq!(key, "boundary.0.region.body");
    assert!(msg.contains("\"nope\"") && msg.contains("\"b\""), "{msg}");
    c.boundaries[0].region.body = Some("b".into());
    c.boundaries[0].region.z_min = Some(0.0);
    assert_eq!(key_of(&c), "boundary.0.region.z_min");
    c.boundaries[0].region.z_min = None;
    c.boundaries[0].region.x_min = Some(1.0);
    c.boundaries[0].region.x_max = Some(0.0);
    assert_eq!(key_of(&c), "boundary.0.region.x_max");
    c.boundaries[0].region.x_max = Some(1.0);
    c.boundaries[0].condition = Condition::Velocity {
        vx: None,
        vy: None,
        vz: None,
        law: TimeLaw::Constant,
        until: None,
    };
    assert_eq!(key_of(&c), "boundary.0.condition");
    c.boundaries[0].condition = Condition::Velocity {
        vx: Some(1.0),
        vy: None,
        vz: Some(0.0),
        law: TimeLaw::Constant,
        until: None,
    };
    assert_eq!(key_of(&c), "boundary.0.condition.vz");
    c.boundaries[0].condition = Condition::Velocity {
        vx: Some(1.0),
        vy: None,
        vz: None,
        law: TimeLaw::Constant,
        until: Some(0.0),
    };
    assert_eq!(key_of(&c), "boundary.0.condition.until");
    c.boundaries[0].condition = Condition::Velocity {
        vx: Some(1.0),
        vy: None,
        vz: None,
        law: TimeLaw::Ramp { duration: -1.0 },
        until: None,
    };
    assert_eq!(key_of(&c), "boundary.0.condition.law.duration");
    c.boundaries[0].condition = Condition::Symmetry { normal: Axis::Z };
    let (key, msg) = check(&c).unwrap_err();
    assert_eq!(key, "boundary.0.condition.normal");
    assert!(msg.contains("\"z\""), "{msg}");
    c.boundaries[0].condition = Condition::Traction {
        traction: vec![1.0],
        law: TimeLaw::Constant,
    };
    assert_eq!(key_of(&c), "boundary.0.condition.traction");
    c.boundaries.clear();
    c.run.energy_growth_limit = 1.0;
    assert_eq!(key_of(&c), "run.energy_growth_limit");
    c.run.energy_growth_limit = 10.0;
    c.output.observers = vec![Observer::Energy, Observer::NeckHeight, Observer::NeckHeight];
    let (key, msg) = check(&c).unwrap_err();
    assert_eq!(key, "output.observers");
    assert!(msg.contains("\"neck-height\""), "{msg}");
    c.output.observers.pop();
    c.output.frame_interval = Some(0.0);
    assert_eq!(key_of(&c), "output.frame_interval");
    c.output.frame_interval = None;
    c.probes.push(ProbeSpec {
        name: "tip.x".into(),
        position: vec![0.0, 0.0],
    });
    assert_eq!(key_of(&c), "probe.0.name");
    c.probes[0].name = "tip".into();
    let probe = c.probes[0].clone();
    c.probes.push(probe);
    assert_eq!(key_of(&c), "probe.1.name");
    c.probes[1].name = "mid".into();
    c.probes[1].position = vec![0.0];
    assert_eq!(key_of(&c), "probe.1.position");
}

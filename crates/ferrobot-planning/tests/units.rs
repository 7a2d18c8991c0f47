//! Smaller pieces of the planning crate against hand-derived references:
//! shortcutting in free space (the straight segment), path lengths, and the
//! reading of configurations given in other joint orders (locked-joint
//! overrides, mimic joints), which the Python bindings delegate here.

use std::sync::Arc;

use ferrobot_collision::{
    AllowedCollisions, CollisionChecker, CollisionWorld, RobotSpheres, Sphere,
};
use ferrobot_model::{LoadOptions, ModelError, RobotModel};
use ferrobot_planning::simplify::path_length;
use ferrobot_planning::{
    ActiveSpace, Configuration, JointOrder, PlanOptions, Planner, PlanningError,
};
use nalgebra::Point3;

/// A ball on x and y slides (the planned chain), a z slide beside it (not
/// planned) and a mimic joint `z2 = 2 z + 0.1`.
fn model() -> Arc<RobotModel> {
    let urdf = r#"<robot name="slider">
      <link name="base"/>
      <link name="carriage"/>
      <link name="ball"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
      <link name="lift"/>
      <link name="lift2"/>
      <joint name="x" type="prismatic"><parent link="base"/><child link="carriage"/>
        <axis xyz="1 0 0"/><limit lower="-1" upper="1" velocity="1" effort="10"/></joint>
      <joint name="y" type="prismatic"><parent link="carriage"/><child link="ball"/>
        <axis xyz="0 1 0"/><limit lower="-1" upper="1" velocity="1" effort="10"/></joint>
      <joint name="z" type="prismatic"><parent link="base"/><child link="lift"/>
        <axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="10"/></joint>
      <joint name="z2" type="prismatic"><parent link="lift"/><child link="lift2"/>
        <axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1" effort="10"/>
        <mimic joint="z" multiplier="2" offset="0.1"/></joint>
    </robot>"#;
    let opts = LoadOptions {
        ee_link: Some("ball".into()),
        ..LoadOptions::default()
    };
    Arc::new(RobotModel::from_urdf_str(urdf, &opts).unwrap())
}

fn dof(model: &RobotModel, name: &str) -> usize {
    model.dof(name).unwrap()
}

/// The active space of x and y (z locked at 0).
fn space(model: &RobotModel) -> ActiveSpace {
    let mut d = vec![dof(model, "x"), dof(model, "y")];
    d.sort_unstable();
    ActiveSpace::new(model, &d).unwrap()
}

fn names(n: &[&str]) -> Vec<String> {
    n.iter().map(|s| s.to_string()).collect()
}

#[test]
fn configuration_in_another_order_sets_locked_joints_only_when_they_differ() {
    let m = model();
    let s = space(&m);
    assert_eq!(s.names, names(&["x", "y"]));
    let order = JointOrder::new(&m, &s, &names(&["z", "y", "x"])).unwrap();
    // z = 0 is the locked value: no override.
    let c = Configuration::read(&m, &s, Some(&order), "q", &[0.0, 0.2, 0.1]).unwrap();
    assert_eq!(c.active, vec![0.1, 0.2]);
    assert_eq!(c.full, None);
    assert_eq!(c.locked_override(&s), None);
    // z = 0.3 overrides it: the full configuration (DOF order) holds it.
    let c = Configuration::read(&m, &s, Some(&order), "q", &[0.3, 0.2, 0.1]).unwrap();
    let mut want = vec![0.0; m.num_dof()];
    want[dof(&m, "x")] = 0.1;
    want[dof(&m, "y")] = 0.2;
    want[dof(&m, "z")] = 0.3;
    assert_eq!(c.full.as_deref(), Some(want.as_slice()));
    assert_eq!(c.locked_override(&s), Some(want.clone()));
    assert_eq!(c.clone().into_full(&s), want);
    // Back into the user's order: the mimic joint follows 2 z + 0.1, with z
    // at the space's locked value.
    let order2 = JointOrder::new(&m, &s, &names(&["z2", "x", "y"])).unwrap();
    let mut locked = s.clone();
    locked.lock_from(&want);
    let out = order2.from_active(&locked, &[0.1, 0.2]);
    assert!((out[0] - (2.0 * 0.3 + 0.1)).abs() < 1e-15);
    assert_eq!(&out[1..], &[0.1, 0.2]);
    // Velocities: the mimic joint's derivative is 0 (its driver is locked).
    assert_eq!(
        order2.derivative_from_active(&s, &[1.0, 2.0]),
        vec![0.0, 1.0, 2.0]
    );
}

#[test]
fn configuration_without_an_order_is_active_or_full() {
    let m = model();
    let s = space(&m);
    let c = Configuration::read(&m, &s, None, "q", &[0.1, 0.2]).unwrap();
    assert_eq!((c.active, c.full), (vec![0.1, 0.2], None));
    let mut full = vec![0.0; m.num_dof()];
    full[dof(&m, "x")] = -0.4;
    full[dof(&m, "y")] = 0.5;
    let c = Configuration::read(&m, &s, None, "q", &full).unwrap();
    assert_eq!(c.active, vec![-0.4, 0.5]);
    // A full vector sets the locked joints as given (the whole vector is
    // the override, as the request carries it).
    assert_eq!(c.locked_override(&s), Some(full.clone()));
    assert_eq!(c.into_full(&s), full);
    let err = Configuration::read(&m, &s, None, "start", &[0.0; 5]).unwrap_err();
    match err {
        PlanningError::Model(ModelError::Shape { what, got, .. }) => {
            assert_eq!((what.as_str(), got.as_str()), ("start", "(5,)"));
        }
        other => panic!("expected a shape error, got {other:?}"),
    }
    // Orders must name every planned joint, once.
    assert!(JointOrder::new(&m, &s, &names(&["x", "z"])).is_err());
    assert!(JointOrder::new(&m, &s, &names(&["x", "y", "x"])).is_err());
}

#[test]
fn dof_columns_skip_mimic_joints_and_refuse_unknown_names() {
    let m = model();
    let cols = m.dof_columns(&names(&["y", "z2", "x"])).unwrap();
    assert_eq!(cols, vec![(0, dof(&m, "y")), (2, dof(&m, "x"))]);
    assert!(matches!(
        m.dof_columns(&names(&["x", "w"])),
        Err(ModelError::UnknownName { .. })
    ));
}

#[test]
fn path_length_of_a_polyline() {
    // 3-4-5 and 5-12-13 right triangles: 5 + 13.
    let p = vec![vec![0.0, 0.0], vec![3.0, 4.0], vec![8.0, 16.0]];
    assert!((path_length(&p) - 18.0).abs() < 1e-12);
    assert_eq!(path_length(&p[..1]), 0.0);
}

/// A planner over x and y with no obstacle.
fn free_planner() -> Planner {
    let m = model();
    let ball = m.link("ball").unwrap();
    let mut links = vec![Vec::new(); m.links().len()];
    links[ball] = vec![Sphere::new(Point3::origin(), 0.05)];
    let spheres = RobotSpheres::new(&m, links).unwrap();
    let acm = AllowedCollisions::from_model(&m);
    let checker = CollisionChecker::new(m.clone(), spheres, acm, CollisionWorld::new()).unwrap();
    Planner::new(checker, Some(ball)).unwrap()
}

/// In free space the shortest path is the straight segment: shortcutting
/// must reduce any RRT-Connect path (short edges: many vertices) to the two
/// end points, of length |goal - start|; without it the path is at least
/// that long.
#[test]
fn shortcutting_in_free_space_gives_the_straight_segment() {
    let p = free_planner();
    assert_eq!(p.space().names, names(&["x", "y"]));
    let (start, goal) = ([-0.8, -0.8], [0.8, 0.7]);
    let straight = (1.6f64 * 1.6 + 1.5 * 1.5).sqrt();
    for seed in 0..4 {
        let mut opts = PlanOptions::default();
        opts.rrt.seed = seed;
        opts.rrt.range = 0.05;
        opts.simplify_path = false;
        opts.trajectory = false;
        let raw = p.plan(&start, &goal, &opts).unwrap();
        assert!(raw.success(), "{:?}", raw.status);
        assert!(raw.path_length() >= straight - 1e-12);
        opts.simplify_path = true;
        let short = p.plan(&start, &goal, &opts).unwrap();
        assert_eq!(short.path, vec![start.to_vec(), goal.to_vec()]);
        assert!((short.path_length() - straight).abs() < 1e-12);
    }
}

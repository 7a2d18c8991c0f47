//! FK, Jacobians and loading errors on small robots whose answers are
//! written by hand.

use ferrobot_model::{LoadOptions, ModelError, RobotModel};
use nalgebra::Vector3;

const TWO_LINK: &str = r#"<robot name="planar">
  <link name="base"/><link name="upper"/><link name="fore"/><link name="tip"/>
  <link name="pad_a"/><link name="pad_b"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/>
    <origin xyz="0.5 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="wrist" type="fixed"><parent link="fore"/><child link="tip"/><origin xyz="0.25 0 0"/></joint>
  <joint name="slide" type="prismatic"><parent link="tip"/><child link="pad_a"/>
    <axis xyz="0 1 0"/><limit lower="0" upper="0.1" effort="10" velocity="1"/></joint>
  <joint name="slide_mimic" type="prismatic"><parent link="tip"/><child link="pad_b"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="1"/>
    <mimic joint="slide" multiplier="-1" offset="0.02"/></joint>
</robot>"#;

fn model() -> RobotModel {
    RobotModel::from_urdf_str(TWO_LINK, &LoadOptions::default()).unwrap()
}

#[test]
fn planar_two_link_fk_by_hand() {
    let m = model();
    assert_eq!(m.dof_names(), ["shoulder", "elbow", "slide"]);
    assert_eq!(m.links()[m.ee_link()].name, "tip");
    for &(a, b, s) in &[(0.0, 0.0, 0.0), (0.3, -1.1, 0.05), (2.5, 1.0, 0.1)] {
        let q = [a, b, s];
        let tip = m.fk(&q, None).unwrap();
        let expected = Vector3::new(
            0.5 * f64::cos(a) + 0.25 * f64::cos(a + b),
            0.5 * f64::sin(a) + 0.25 * f64::sin(a + b),
            0.0,
        );
        assert!((tip.translation.vector - expected).norm() < 1e-12);
        let expected_rot = nalgebra::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a + b);
        assert!(tip.rotation.angle_to(&expected_rot) < 1e-9);
        let y = tip.rotation * Vector3::y();
        let pad_b = m.fk(&q, Some(m.link("pad_b").unwrap())).unwrap();
        assert!((pad_b.translation.vector - (expected + y * (0.02 - s))).norm() < 1e-12);
        let all = m.fk_all(&q).unwrap();
        assert!(
            (all[m.link("pad_b").unwrap()].translation.vector - pad_b.translation.vector).norm()
                < 1e-12
        );
    }
}

#[test]
fn jacobian_by_hand() {
    let m = model();
    let (a, b) = (0.4, 0.7);
    let j = m.jacobian(&[a, b, 0.0], None).unwrap();
    let n = m.num_dof();
    // d tip / d shoulder = z x p_tip, d tip / d elbow = z x (p_tip - p_elbow)
    let col = |c: usize| Vector3::new(j[c], j[n + c], j[2 * n + c]);
    let expected_shoulder = Vector3::new(
        -0.5 * a.sin() - 0.25 * (a + b).sin(),
        0.5 * a.cos() + 0.25 * (a + b).cos(),
        0.0,
    );
    let expected_elbow = Vector3::new(-0.25 * (a + b).sin(), 0.25 * (a + b).cos(), 0.0);
    assert!((col(0) - expected_shoulder).norm() < 1e-12);
    assert!((col(1) - expected_elbow).norm() < 1e-12);
    assert_eq!(col(2), Vector3::zeros()); // the slide does not move the tip
    assert_eq!((j[3 * n], j[4 * n], j[5 * n]), (0.0, 0.0, 1.0)); // angular of shoulder
    // the mimic pad moves with gain -1 along the tip's y axis
    let jb = m
        .jacobian(&[a, b, 0.0], Some(m.link("pad_b").unwrap()))
        .unwrap();
    let y = Vector3::new(-(a + b).sin(), (a + b).cos(), 0.0);
    assert!((Vector3::new(jb[2], jb[n + 2], jb[2 * n + 2]) + y).norm() < 1e-12);
}

#[test]
fn batch_matches_single() {
    let m = model();
    let qs: Vec<f64> = (0..300)
        .flat_map(|i| [i as f64 * 0.01, -(i as f64) * 0.02, 0.001 * i as f64])
        .collect();
    let batch = m.fk_batch(&qs, None).unwrap();
    for (i, q) in qs.chunks(3).enumerate() {
        let p = ferrobot_model::pose_to_array(&m.fk(q, None).unwrap());
        assert_eq!(&batch[i * 7..i * 7 + 7], &p);
    }
}

#[test]
fn bad_configurations_are_errors_not_panics() {
    let m = model();
    assert!(matches!(
        m.fk(&[0.0, 0.0], None),
        Err(ModelError::Shape { .. })
    ));
    assert!(matches!(
        m.fk(&[0.0, f64::NAN, 0.0], None),
        Err(ModelError::NonFinite { index: 1, .. })
    ));
    assert!(matches!(
        m.fk_batch(&[0.0; 4], None),
        Err(ModelError::Shape { .. })
    ));
    assert!(matches!(
        m.link("nope"),
        Err(ModelError::UnknownName { .. })
    ));
}

#[test]
fn loading_errors_name_the_problem() {
    let load = |t: &str| {
        RobotModel::from_urdf_str(t, &LoadOptions::default())
            .unwrap_err()
            .to_string()
    };
    assert!(
        load("<robot name='r'><link name='a'/><link name='b'/></robot>")
            .contains("2 root links (a, b)")
    );
    let e = load(
        "<robot name='r'>\n<link name='a'/>\n<link name='b'/>\n<joint name='j' type='ball'><parent link='a'/><child link='b'/></joint></robot>",
    );
    assert!(
        e.starts_with("<string>:4: joint 'j' has unknown type 'ball'"),
        "{e}"
    );
    assert!(load("<robot name='r'><link name='a'></robot>").contains("malformed XML"));
    let e = load(
        "<robot name='r'><link name='a'/><link name='b'/><joint name='j' type='fixed'><parent link='a'/><child link='b'/><mimic joint='x'/></joint><joint name='k' type='continuous'><parent link='b'/><child link='a'/></joint></robot>",
    );
    assert!(e.contains("kinematic loop"), "{e}");
}

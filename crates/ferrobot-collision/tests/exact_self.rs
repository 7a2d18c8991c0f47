//! The exact self-collision stage against an independent reference (parry
//! convex polyhedra of the links' meshes, posed by the model's f64 forward
//! kinematics), and the collision explanation (`contacts`) against
//! `in_collision`.

mod common;

use common::{hulls, mbm_panda, random_q, shared, to_pose};

use std::sync::Arc;

use ferrobot_collision::spherize::{SpherizeOptions, spherize_robot};
use ferrobot_collision::{AllowedCollisions, CollisionChecker, CollisionWorld, RobotSpheres};
use parry3d::query::contact;
use rand::{SeedableRng, rngs::StdRng};

#[test]
fn exact_self_collision_matches_convex_hull_reference() {
    let (model, spheres, acm) = mbm_panda();
    let link_spheres = spheres.links.clone();
    let checker =
        CollisionChecker::new(model.clone(), spheres, acm, CollisionWorld::new()).unwrap();
    let mut spheres_only = checker.clone();
    spheres_only.set_exact_self_collision(false);
    let hulls = hulls(&model);
    let (robot, _) = checker.compiled();
    let pairs: Vec<(usize, usize)> = robot
        .pairs
        .iter()
        .map(|&(a, b)| (robot.bodies[a].link, robot.bodies[b].link))
        .collect();
    let mut rng = StdRng::seed_from_u64(21);
    let (mut deep, mut filtered, mut disagree, n) = (0, 0, 0, 3000);
    for _ in 0..n {
        let q = random_q(&model, &mut rng);
        let poses = model.fk_all(&q).unwrap();
        // Reference: the deepest penetration of any checked pair's hulls.
        // Reference: the deepest penetration of the hulls of any checked
        // pair whose spheres overlap (the exact stage decides only there;
        // a hand-made sphere model need not cover the hulls).
        let mut depth = f32::INFINITY;
        for &(a, b) in &pairs {
            let overlap = link_spheres[a]
                .iter()
                .flat_map(|sa| link_spheres[b].iter().map(move |sb| (sa, sb)))
                .map(|(sa, sb)| {
                    sa.radius + sb.radius - (poses[a] * sa.center - poses[b] * sb.center).norm()
                })
                .fold(f64::NEG_INFINITY, f64::max);
            if overlap <= 0.0 {
                continue;
            }
            for (oa, ha) in &hulls[a] {
                for (ob, hb) in &hulls[b] {
                    let (pa, pb) = (to_pose(&(poses[a] * oa)), to_pose(&(poses[b] * ob)));
                    if let Some(c) = contact(&pa, ha, &pb, hb, 0.0).unwrap() {
                        // Clear overlaps only: both stages agree beyond rounding.
                        let d = if overlap > 1e-4 {
                            c.dist
                        } else {
                            c.dist.max(0.0)
                        };
                        depth = depth.min(d);
                    }
                }
            }
        }
        let got = checker.in_collision(&q).unwrap();
        if depth < -1e-4 {
            deep += 1;
            assert!(got, "hulls penetrate {depth} m, checker says free at {q:?}");
        }
        if (depth <= 0.0) != got {
            disagree += 1;
        }
        if spheres_only.in_collision(&q).unwrap() && !got {
            filtered += 1;
        }
    }
    // Only configurations at a touching boundary may differ (f32 lanes).
    assert!(disagree <= n / 500, "{disagree} of {n} disagree");
    assert!(deep > 100 && filtered > 10, "{deep} {filtered}");
}

#[test]
fn contacts_agree_with_in_collision() {
    let (model, spheres, acm) = mbm_panda();
    let world =
        CollisionWorld::from_moveit_scene(shared("bench/mbm/bookshelf_small_panda/scene0002.yaml"))
            .unwrap();
    let checker = CollisionChecker::new(model.clone(), spheres, acm, world).unwrap();
    let mut spheres_only = checker.clone();
    spheres_only.set_exact_self_collision(false);
    let mut rng = StdRng::seed_from_u64(5);
    let (mut hits, mut free, mut sphere_only_self) = (0, 0, 0);
    for _ in 0..1500 {
        let q = random_q(&model, &mut rng);
        let got = checker.in_collision(&q).unwrap();
        let contacts = checker.contacts(&q).unwrap();
        assert_eq!(got, !contacts.is_empty(), "{q:?}: {contacts:?}");
        if got {
            hits += 1;
        } else {
            free += 1;
        }
        // Self-contacts the spheres alone would list but the geometry rules out.
        let listed =
            |c: &[ferrobot_collision::Contact]| c.iter().filter(|c| c.self_collision).count();
        if listed(&spheres_only.contacts(&q).unwrap()) > listed(&contacts) {
            sphere_only_self += 1;
        }
    }
    assert!(
        hits > 100 && free > 100 && sphere_only_self > 10,
        "{hits} {free} {sphere_only_self}"
    );
    // Elbow fully bent: the hand comes back onto link 1, a real contact
    // that the explanation names.
    let folded = [0.0, 0.0, 0.0, -3.0, 0.0, 0.5, 0.0];
    assert!(checker.in_collision(&folded).unwrap());
    let contacts = checker.contacts(&folded).unwrap();
    assert!(
        contacts
            .iter()
            .any(|c| c.self_collision && c.body == "panda_link1" && c.other == "panda_hand"),
        "{contacts:?}"
    );
}

#[test]
fn bundled_panda_ready_is_free_and_unexplained() {
    let model = Arc::new(ferrobot_model::robots::panda().unwrap());
    let (links, _) = spherize_robot(&model, &SpherizeOptions::default()).unwrap();
    let spheres = RobotSpheres::new(&model, links).unwrap();
    let acm = AllowedCollisions::from_model(&model);
    let checker =
        CollisionChecker::new(model.clone(), spheres, acm, CollisionWorld::new()).unwrap();
    let ready = model.named_state("ready", None).unwrap();
    assert!(!checker.in_collision(&ready).unwrap());
    assert!(checker.contacts(&ready).unwrap().is_empty());
    let batch = checker.in_collision_batch(&ready).unwrap();
    assert_eq!(batch, vec![false]);
}

/// The kernels take the exact stage's cheap steps (boxes, inscribed
/// spheres) pair by pair and leave the pairs that need GJK (and the mesh
/// refinement) until every other test of the check has run; the mesh
/// refinement tests its cheap containment conditions before the triangles.
/// Only the order of the work changes: every kernel (batch, serial batch,
/// single) must still give, configuration by configuration, the answer of
/// the collision explanation (`contacts`), which decides each self pair in
/// turn by its spheres (`f64`) and the whole exact stage, and the world
/// contacts by exact signed distances. Mostly self-colliding random
/// configurations (elbow and wrist folded), in an empty and a crowded world.
#[test]
fn deferred_exact_stage_answers_as_pair_by_pair_confirmation() {
    let (model, spheres, acm) = mbm_panda();
    let mut rng = StdRng::seed_from_u64(23);
    for (wi, world) in [
        CollisionWorld::new(),
        common::scattered_world(3, 150, 0.8, 0.0..1.2, 0.01..0.04, 4),
    ]
    .into_iter()
    .enumerate()
    {
        let checker =
            CollisionChecker::new(model.clone(), spheres.clone(), acm.clone(), world).unwrap();
        let mut spheres_only = checker.clone();
        spheres_only.set_exact_self_collision(false);
        let n = 2000;
        let mut qs = Vec::with_capacity(n * 7);
        for k in 0..n {
            let mut q = random_q(&model, &mut rng);
            if k % 2 == 0 {
                // Elbow folded (joint 4 near its lower limit), wrist bent:
                // the hand and links 5-7 come close to links 0-4.
                q[3] = -3.0 + 0.4 * (k % 7) as f64 / 7.0;
            }
            qs.extend(q);
        }
        let batch = checker.in_collision_batch(&qs).unwrap();
        let mut serial = vec![false; n];
        checker.in_collision_batch_serial_into(&qs, &mut serial);
        let (mut hits, mut filtered, mut disagree) = (0, 0, 0);
        for (k, q) in qs.chunks_exact(7).enumerate() {
            let single = checker.in_collision(q).unwrap();
            assert_eq!(single, batch[k], "single vs batch at {q:?}");
            assert_eq!(serial[k], batch[k], "serial vs batch at {q:?}");
            let explained = !checker.contacts(q).unwrap().is_empty();
            // Only a contact that exactly touches may differ (f64 spheres
            // in the explanation, f32 lanes in the kernels).
            if explained != single {
                disagree += 1;
            }
            hits += usize::from(single);
            filtered += usize::from(spheres_only.in_collision(q).unwrap() && !single);
        }
        assert!(
            disagree <= n / 1000,
            "world {wi}: {disagree} of {n} disagree"
        );
        // The exact stage decided many configurations either way.
        assert!(
            hits > n / 10 && filtered > 20,
            "world {wi}: {hits} {filtered}"
        );
    }
}

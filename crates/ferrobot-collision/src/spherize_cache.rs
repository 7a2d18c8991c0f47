//! A cache of automatic sphere models, so that a robot is spherized once
//! (seconds of CPU) and not again each time it is loaded: in memory for the
//! process, and on disk across processes (test runs, benchmarks, a user's
//! sessions).
//!
//! The key is a 64-bit FNV-1a hash of everything the result depends on:
//! [`CACHE_VERSION`] (bumped whenever the spherizer's output changes), the
//! options, and per link its name and collision geometry (shape kinds,
//! sizes, origins, mesh scales and every vertex and triangle). The spherizer
//! is deterministic, so a hit is the result a new run would give.
//!
//! The disk cache lives in the `spheres/` folder of the one cache root
//! ([`ferrobot_geometry::cache`]: `$FERROBOT_CACHE_DIR`, else
//! `$XDG_CACHE_HOME/ferrobot`, else `$HOME/.cache/ferrobot`);
//! `FERROBOT_CACHE_DIR=off` turns it off (the memory cache stays). It is only an optimisation: a file that cannot be read, written
//! or parsed is ignored and the model is computed.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Mutex, OnceLock};

use nalgebra::{Isometry3, Point3};

use ferrobot_model::{Geometry, Shape};

use crate::sphere::Sphere;
use crate::spherize::{LinkSphereReport, SpherizeOptions};

/// Changes whenever the spherizer's output for the same input changes.
pub const CACHE_VERSION: u64 = 2;

/// Most entries kept in memory (whole robots).
const MEMORY_ENTRIES: usize = 64;

/// One robot's result: spheres per link and the reports.
pub(crate) type Entry = (Vec<Vec<Sphere>>, Vec<LinkSphereReport>);

struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 = (self.0 ^ u64::from(x)).wrapping_mul(0x0100_0000_01b3);
        }
    }
    fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.u64(v.to_bits());
    }
    fn str(&mut self, s: &str) {
        self.u64(s.len() as u64);
        self.bytes(s.as_bytes());
    }
    fn iso(&mut self, o: &Isometry3<f64>) {
        o.translation.vector.iter().for_each(|&v| self.f64(v));
        o.rotation.coords.iter().for_each(|&v| self.f64(v));
    }
    fn points(&mut self, pts: &[Point3<f64>]) {
        self.u64(pts.len() as u64);
        for p in pts {
            p.coords.iter().for_each(|&v| self.f64(v));
        }
    }
}

/// The key of a robot's links (name and collision geometry) and options.
pub(crate) fn key(links: &[(&str, &[Geometry])], options: &SpherizeOptions) -> u64 {
    let mut h = Fnv::new();
    h.u64(CACHE_VERSION);
    h.f64(options.tolerance);
    h.u64(options.total_budget.map_or(u64::MAX, |n| n as u64));
    h.u64(options.max_per_link.map_or(u64::MAX, |n| n as u64));
    h.f64(options.sample_spacing);
    h.u64(options.seed);
    h.u64(links.len() as u64);
    for (name, geoms) in links {
        h.str(name);
        h.u64(geoms.len() as u64);
        for g in geoms.iter() {
            h.iso(&g.origin);
            h.str(g.shape.kind());
            match &g.shape {
                Shape::Box { half_extents } => half_extents.iter().for_each(|&v| h.f64(v)),
                Shape::Sphere { radius } => h.f64(*radius),
                Shape::Cylinder {
                    radius,
                    half_height,
                }
                | Shape::Capsule {
                    radius,
                    half_height,
                } => {
                    h.f64(*radius);
                    h.f64(*half_height);
                }
                Shape::Mesh(m) | Shape::ConvexDecomposition(m) => {
                    m.scale().iter().for_each(|&v| h.f64(v));
                    h.points(&m.data().vertices);
                    for t in &m.data().triangles {
                        t.iter().for_each(|&i| h.u64(u64::from(i)));
                    }
                }
                Shape::ConvexHull(hull) => {
                    let m = hull.surface();
                    m.scale().iter().for_each(|&v| h.f64(v));
                    h.points(&m.data().vertices);
                    for t in &m.data().triangles {
                        t.iter().for_each(|&i| h.u64(u64::from(i)));
                    }
                }
                Shape::PointCloud(_) => h.str("cloud"),
            }
        }
    }
    h.0
}

fn memory() -> &'static Mutex<HashMap<u64, Entry>> {
    static M: OnceLock<Mutex<HashMap<u64, Entry>>> = OnceLock::new();
    M.get_or_init(|| Mutex::new(HashMap::new()))
}

fn dir() -> Option<PathBuf> {
    ferrobot_geometry::cache::cache_dir("spheres")
}

/// Text form: per link `link NAME COUNT` then `x y z r` lines, then the
/// reports `report NAME spheres coverage mean max`. Floats in Rust's
/// shortest round-trip form, so a read gives back the same bits.
fn encode(entry: &Entry) -> String {
    let mut s = format!("ferrobot-spheres {CACHE_VERSION}\n");
    for (l, spheres) in entry.0.iter().enumerate() {
        s += &format!("link {l} {}\n", spheres.len());
        for sp in spheres {
            s += &format!(
                "{:?} {:?} {:?} {:?}\n",
                sp.center.x, sp.center.y, sp.center.z, sp.radius
            );
        }
    }
    for r in &entry.1 {
        s += &format!(
            "report {} {:?} {:?} {:?} {}\n",
            r.spheres, r.coverage, r.mean_protrusion, r.max_protrusion, r.link
        );
    }
    s
}

fn decode(text: &str, links: usize) -> Option<Entry> {
    let mut lines = text.lines();
    if lines.next()? != format!("ferrobot-spheres {CACHE_VERSION}") {
        return None;
    }
    let mut spheres = Vec::with_capacity(links);
    let mut reports = Vec::new();
    while let Some(line) = lines.next() {
        let mut w = line.split(' ');
        match w.next()? {
            "link" => {
                let l: usize = w.next()?.parse().ok()?;
                let n: usize = w.next()?.parse().ok()?;
                if l != spheres.len() {
                    return None;
                }
                let mut v = Vec::with_capacity(n);
                for _ in 0..n {
                    let f: Vec<f64> = lines
                        .next()?
                        .split(' ')
                        .map(|x| x.parse().ok())
                        .collect::<Option<_>>()?;
                    let [x, y, z, r] = f[..] else { return None };
                    v.push(Sphere::new(Point3::new(x, y, z), r));
                }
                spheres.push(v);
            }
            "report" => {
                let n: usize = w.next()?.parse().ok()?;
                let c: f64 = w.next()?.parse().ok()?;
                let mean: f64 = w.next()?.parse().ok()?;
                let max: f64 = w.next()?.parse().ok()?;
                let name = w.collect::<Vec<_>>().join(" ");
                reports.push(LinkSphereReport {
                    link: name,
                    spheres: n,
                    coverage: c,
                    mean_protrusion: mean,
                    max_protrusion: max,
                });
            }
            _ => return None,
        }
    }
    (spheres.len() == links).then_some((spheres, reports))
}

/// The cached result for `key` (memory, then disk), if any.
pub(crate) fn get(key: u64, links: usize) -> Option<Entry> {
    if let Some(e) = memory().lock().ok()?.get(&key) {
        return Some(e.clone());
    }
    let path = dir()?.join(format!("{key:016x}.txt"));
    let entry = decode(&std::fs::read_to_string(path).ok()?, links)?;
    put_memory(key, &entry);
    Some(entry)
}

fn put_memory(key: u64, entry: &Entry) {
    if let Ok(mut m) = memory().lock() {
        if m.len() >= MEMORY_ENTRIES {
            m.clear();
        }
        m.insert(key, entry.clone());
    }
}

/// Stores `entry` under `key` (memory and, when possible, disk: written to a
/// temporary file and renamed, so readers never see half a file).
pub(crate) fn put(key: u64, entry: &Entry) {
    put_memory(key, entry);
    let Some(dir) = dir() else { return };
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    let tmp = dir.join(format!("{key:016x}.{}.tmp", std::process::id()));
    if std::fs::write(&tmp, encode(entry)).is_ok()
        && std::fs::rename(&tmp, dir.join(format!("{key:016x}.txt"))).is_err()
    {
        let _ = std::fs::remove_file(&tmp);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encoding_round_trips_exactly() {
        let entry: Entry = (
            vec![
                vec![Sphere::new(
                    Point3::new(0.1, -2e-17, 1.0 / 3.0),
                    0.0123456789,
                )],
                vec![],
            ],
            vec![LinkSphereReport {
                link: "a link".into(),
                spheres: 1,
                coverage: 1.0,
                mean_protrusion: 0.003,
                max_protrusion: 0.0099,
            }],
        );
        let back = decode(&encode(&entry), 2).expect("decodes");
        assert_eq!(back.1, entry.1);
        assert_eq!(back.0.len(), 2);
        let (a, b) = (&back.0[0][0], &entry.0[0][0]);
        assert_eq!((a.center, a.radius), (b.center, b.radius));
        assert!(decode(&encode(&entry), 3).is_none());
        assert!(decode("garbage", 2).is_none());
    }
}

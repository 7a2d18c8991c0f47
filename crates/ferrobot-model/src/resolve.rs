//! Resolving mesh filenames (`package://`, `file://`, relative, absolute)
//! to files on disk, without shelling out to ROS tools.

use std::path::{Path, PathBuf};

/// Where to look for `package://NAME/...` and relative filenames.
///
/// Roots are tried in order: the explicit `package_dirs`, then each entry of
/// the `ROS_PACKAGE_PATH` environment variable, then the URDF's folder and
/// each of its parents. For a root `R`, `package://NAME/rest` resolves to
/// `R/NAME/rest`, or to `R/rest` when `R` itself is named `NAME`.
#[derive(Debug, Clone, Default)]
pub struct PackageResolver {
    roots: Vec<PathBuf>,
    urdf_dir: Option<PathBuf>,
}

impl PackageResolver {
    /// A resolver for a URDF in `urdf_dir` (None for text given in memory)
    /// with extra `package_dirs`; reads `ROS_PACKAGE_PATH` once.
    pub fn new(urdf_dir: Option<&Path>, package_dirs: &[PathBuf]) -> Self {
        let mut roots: Vec<PathBuf> = package_dirs.to_vec();
        if let Some(env) = std::env::var_os("ROS_PACKAGE_PATH") {
            roots.extend(std::env::split_paths(&env).filter(|p| !p.as_os_str().is_empty()));
        }
        if let Some(dir) = urdf_dir {
            roots.extend(dir.ancestors().map(Path::to_path_buf));
        }
        Self {
            roots,
            urdf_dir: urdf_dir.map(Path::to_path_buf),
        }
    }

    /// The file `filename` refers to, or the list of candidates tried.
    pub fn resolve(&self, filename: &str) -> Result<PathBuf, String> {
        let mut tried = Vec::new();
        if let Some(rest) = filename.strip_prefix("package://") {
            let (package, relative) = rest.split_once('/').unwrap_or((rest, ""));
            if package.is_empty() || relative.is_empty() {
                return Err("a package:// URI needs a package name and a path".into());
            }
            for root in &self.roots {
                let candidates = [
                    Some(root.join(package).join(relative)),
                    (root.file_name().and_then(|n| n.to_str()) == Some(package))
                        .then(|| root.join(relative)),
                ];
                for candidate in candidates.into_iter().flatten() {
                    if candidate.is_file() {
                        return Ok(candidate);
                    }
                    tried.push(candidate);
                }
            }
        } else {
            let plain = filename.strip_prefix("file://").unwrap_or(filename);
            let path = Path::new(plain);
            if path.is_absolute() {
                if path.is_file() {
                    return Ok(path.to_path_buf());
                }
                tried.push(path.to_path_buf());
            } else {
                let bases = self
                    .urdf_dir
                    .iter()
                    .chain(self.roots.iter())
                    .cloned()
                    .chain(std::env::current_dir().ok());
                for base in bases {
                    let candidate = base.join(path);
                    if candidate.is_file() {
                        return Ok(candidate);
                    }
                    tried.push(candidate);
                }
            }
        }
        tried.dedup();
        let shown: Vec<String> = tried
            .iter()
            .take(6)
            .map(|p| p.display().to_string())
            .collect();
        let more = if tried.len() > 6 {
            format!(" and {} more", tried.len() - 6)
        } else {
            String::new()
        };
        Err(format!(
            "file not found (tried {}{more}); pass package_dirs or set ROS_PACKAGE_PATH",
            if shown.is_empty() {
                "nothing".into()
            } else {
                shown.join(", ")
            }
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolves_package_uri_against_named_root_and_parent() {
        let dir = std::env::temp_dir().join(format!("ferrobot-resolve-{}", std::process::id()));
        let pkg = dir.join("my_robot");
        std::fs::create_dir_all(pkg.join("meshes")).unwrap();
        std::fs::create_dir_all(pkg.join("urdf")).unwrap();
        std::fs::write(pkg.join("meshes/a.stl"), b"x").unwrap();
        let resolver = PackageResolver::new(Some(&pkg.join("urdf")), &[]);
        assert_eq!(
            resolver.resolve("package://my_robot/meshes/a.stl").unwrap(),
            pkg.join("meshes/a.stl")
        );
        assert_eq!(
            resolver.resolve("../meshes/a.stl").unwrap(),
            pkg.join("urdf/../meshes/a.stl")
        );
        let err = resolver
            .resolve("package://other/meshes/a.stl")
            .unwrap_err();
        assert!(err.contains("not found"), "{err}");
        let explicit = PackageResolver::new(None, std::slice::from_ref(&dir));
        assert!(explicit.resolve("package://my_robot/meshes/a.stl").is_ok());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

//! Where a file a URDF names (a mesh) is: `package://NAME/rest`, `file://`,
//! absolute and relative paths.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

/// The file that `uri`, written in the URDF at `urdf`, names.
///
/// - `package://NAME/rest` is `P/rest` for the first package directory `P`
///   that exists, looked for in this order: in each of `package_dirs`, then in
///   each directory holding `urdf` and their ancestors (nearest first), then
///   in each entry of `ROS_PACKAGE_PATH`. In a directory `D`, the package is
///   `D` itself when `D` is named `NAME`, else `D/NAME`. (example-robot-data's
///   `package://example-robot-data/robots/...` resolves by walking up from its
///   files to its `example-robot-data` directory.)
/// - `file:///abs` and an absolute path are that path.
/// - Any other path is relative to the directory of `urdf`.
///
/// Errors say which places were tried.
pub fn resolve(uri: &str, urdf: &Path, package_dirs: &[PathBuf]) -> Result<PathBuf, String> {
    let ros = std::env::var_os("ROS_PACKAGE_PATH");
    resolve_in(uri, urdf, package_dirs, ros.as_deref())
}

/// [`resolve`] with the value of `ROS_PACKAGE_PATH` given.
fn resolve_in(
    uri: &str,
    urdf: &Path,
    package_dirs: &[PathBuf],
    ros: Option<&OsStr>,
) -> Result<PathBuf, String> {
    let here = urdf.parent().unwrap_or(Path::new(""));
    let Some(rest) = uri.strip_prefix("package://") else {
        let path = Path::new(uri.strip_prefix("file://").unwrap_or(uri));
        let path = here.join(path); // an absolute `path` stays as it is
        return match path.exists() {
            true => Ok(path),
            false => Err(format!("'{uri}': no file {}", path.display())),
        };
    };
    let (name, inside) = rest.split_once('/').unwrap_or((rest, ""));
    let ancestors = here.ancestors().map(Path::to_path_buf);
    let ros_dirs = ros.map(|r| std::env::split_paths(r).collect::<Vec<_>>());
    let dirs = package_dirs
        .iter()
        .cloned()
        .chain(ancestors)
        .chain(ros_dirs.unwrap_or_default());
    let mut tried = Vec::new();
    for dir in dirs {
        for package in [
            (dir.file_name() == Some(OsStr::new(name))).then(|| dir.clone()),
            Some(dir.join(name)),
        ]
        .into_iter()
        .flatten()
        {
            let path = package.join(inside);
            if package.is_dir() && path.exists() {
                return Ok(path);
            }
            tried.push(path.display().to_string());
        }
    }
    Err(format!(
        "'{uri}': package '{name}' not found (tried {}; add its parent directory to the \
         package directories or ROS_PACKAGE_PATH)",
        tried.join(", ")
    ))
}

#[cfg(test)]
mod tests {
    use std::ffi::OsStr;
    use std::path::{Path, PathBuf};

    use super::resolve_in;

    /// A package tree in a fresh temporary directory:
    /// `root/share/robots/arm_description/{urdf/arm.urdf, meshes/link.stl}`
    /// and `root/elsewhere/tools/gripper.stl`.
    fn packages(test: &str) -> PathBuf {
        let root =
            std::env::temp_dir().join(format!("diffosi-package-{test}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let arm = root.join("share/robots/arm_description");
        for dir in [
            arm.join("urdf"),
            arm.join("meshes"),
            root.join("elsewhere/tools"),
        ] {
            std::fs::create_dir_all(dir).unwrap();
        }
        for file in [
            arm.join("urdf/arm.urdf"),
            arm.join("meshes/link.stl"),
            root.join("elsewhere/tools/gripper.stl"),
        ] {
            std::fs::write(file, "").unwrap();
        }
        root
    }

    #[test]
    fn packages_are_found_by_walking_up_then_in_the_search_paths() {
        let root = packages("walk");
        let urdf = root.join("share/robots/arm_description/urdf/arm.urdf");
        let mesh = root.join("share/robots/arm_description/meshes/link.stl");
        let found =
            |uri: &str, dirs: &[PathBuf], ros: Option<&OsStr>| resolve_in(uri, &urdf, dirs, ros);
        // The file's own package, and a package named by a directory above.
        assert_eq!(
            found("package://arm_description/meshes/link.stl", &[], None),
            Ok(mesh.clone())
        );
        assert_eq!(
            found(
                "package://robots/arm_description/meshes/link.stl",
                &[],
                None
            ),
            Ok(mesh.clone())
        );
        assert_eq!(
            found("../meshes/link.stl", &[], None),
            Ok(urdf.parent().unwrap().join("../meshes/link.stl"))
        );
        let abs = format!("file://{}", mesh.display());
        assert_eq!(found(&abs, &[], None), Ok(mesh.clone()));
        // A package elsewhere: only through the package dirs or ROS_PACKAGE_PATH.
        let gripper = root.join("elsewhere/tools/gripper.stl");
        let uri = "package://tools/gripper.stl";
        let missing = found(uri, &[], None).unwrap_err();
        assert!(missing.contains("package 'tools' not found"), "{missing}");
        assert_eq!(
            found(uri, &[root.join("elsewhere")], None),
            Ok(gripper.clone())
        );
        assert_eq!(
            found(uri, &[root.join("elsewhere/tools")], None),
            Ok(gripper.clone())
        );
        let ros = std::env::join_paths([Path::new("/nowhere"), &root.join("elsewhere")]).unwrap();
        assert_eq!(found(uri, &[], Some(&ros)), Ok(gripper));
        // The package dirs come first.
        let copy = root.join("first/arm_description/meshes");
        std::fs::create_dir_all(&copy).unwrap();
        std::fs::write(copy.join("link.stl"), "").unwrap();
        let uri = "package://arm_description/meshes/link.stl";
        assert_eq!(
            found(uri, &[root.join("first")], None),
            Ok(copy.join("link.stl"))
        );
        let _ = std::fs::remove_dir_all(&root);
    }
}

//! A recorded TCP trajectory as CSV (lead-through teaching, `nextpose segment`).
//!
//! The first row names the columns: `t` (seconds) and `x`, `y` (mm) are required; `z` (mm) and
//! the quaternion `qw`, `qx`, `qy`, `qz` are optional (a missing `z` is 0, a missing quaternion
//! the identity; a quaternion is all four columns or none); joint columns `j1`, `j2`, … are
//! optional. Other columns are refused so a misspelt name is not silently ignored. Blank lines
//! and lines starting with `#` are skipped. Every value must be a finite number, and each pose
//! one the service accepts ([`PoseValues::to_pose`]: coordinates within ±100,000 mm).

use thiserror::Error;

use crate::engine::PoseValues;
use crate::engine::lead_through::segment::TimedPose;

/// One sample of the file.
#[derive(Debug, Clone, PartialEq)]
pub struct TrajectorySample {
    pub sample: TimedPose,
    /// Joint values (the file's `j1…` columns), when present.
    pub joints: Option<Vec<f64>>,
}

/// What is wrong with a trajectory file.
#[derive(Debug, Error)]
pub enum TrajectoryFileError {
    #[error("the header has no column {0:?} (it needs t, x and y)")]
    MissingColumn(&'static str),
    #[error("column {0:?} is not one of t, x, y, z, qw, qx, qy, qz, j1, j2, …")]
    UnknownColumn(String),
    #[error("column {0:?} appears twice")]
    DuplicateColumn(String),
    #[error("a quaternion needs all of qw, qx, qy and qz")]
    PartialQuaternion,
    #[error("joint columns must be j1 to jN without gaps")]
    JointGap,
    #[error("line {line}: {message}")]
    Row { line: u64, message: String },
    #[error("CSV: {0}")]
    Csv(#[from] csv::Error),
}

#[derive(Default)]
struct Columns {
    t: Option<usize>,
    pos: [Option<usize>; 3],
    quat: [Option<usize>; 4],
    joints: Vec<(usize, usize)>,
}

fn columns(header: &csv::StringRecord) -> Result<Columns, TrajectoryFileError> {
    let mut c = Columns::default();
    for (i, name) in header.iter().enumerate() {
        let name = name.trim();
        let slot = match name {
            "t" => &mut c.t,
            "x" => &mut c.pos[0],
            "y" => &mut c.pos[1],
            "z" => &mut c.pos[2],
            "qw" => &mut c.quat[0],
            "qx" => &mut c.quat[1],
            "qy" => &mut c.quat[2],
            "qz" => &mut c.quat[3],
            other => {
                let n = other
                    .strip_prefix('j')
                    .and_then(|n| n.parse::<usize>().ok())
                    .filter(|n| *n >= 1)
                    .ok_or_else(|| TrajectoryFileError::UnknownColumn(other.to_string()))?;
                if c.joints.iter().any(|(j, _)| *j == n) {
                    return Err(TrajectoryFileError::DuplicateColumn(other.to_string()));
                }
                c.joints.push((n, i));
                continue;
            }
        };
        if slot.replace(i).is_some() {
            return Err(TrajectoryFileError::DuplicateColumn(name.to_string()));
        }
    }
    if c.t.is_none() {
        return Err(TrajectoryFileError::MissingColumn("t"));
    }
    for (k, name) in [(0, "x"), (1, "y")] {
        if c.pos[k].is_none() {
            return Err(TrajectoryFileError::MissingColumn(name));
        }
    }
    let present = c.quat.iter().filter(|q| q.is_some()).count();
    if present != 0 && present != 4 {
        return Err(TrajectoryFileError::PartialQuaternion);
    }
    c.joints.sort_unstable();
    if c.joints.iter().enumerate().any(|(k, (n, _))| *n != k + 1) {
        return Err(TrajectoryFileError::JointGap);
    }
    Ok(c)
}

/// Reads a trajectory from CSV text (see the module docs).
pub fn parse_trajectory(text: &str) -> Result<Vec<TrajectorySample>, TrajectoryFileError> {
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(text.as_bytes());
    let c = columns(reader.headers()?)?;
    let mut out = Vec::new();
    for record in reader.records() {
        let record = record?;
        let line = record.position().map_or(0, |p| p.line());
        let row = |message: String| TrajectoryFileError::Row { line, message };
        let value = |i: Option<usize>, name: &str, default: f64| -> Result<f64, _> {
            let Some(i) = i else { return Ok(default) };
            let raw = record.get(i).unwrap_or("");
            match raw.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(row(format!("{name} = {raw:?} is not a finite number"))),
            }
        };
        let t = value(c.t, "t", 0.0)?;
        let p = [
            value(c.pos[0], "x", 0.0)?,
            value(c.pos[1], "y", 0.0)?,
            value(c.pos[2], "z", 0.0)?,
        ];
        let q = [
            value(c.quat[0], "qw", 1.0)?,
            value(c.quat[1], "qx", 0.0)?,
            value(c.quat[2], "qy", 0.0)?,
            value(c.quat[3], "qz", 0.0)?,
        ];
        let values = PoseValues {
            x: p[0],
            y: p[1],
            z: p[2],
            qw: q[0],
            qx: q[1],
            qy: q[2],
            qz: q[3],
        };
        let pose = values.to_pose().map_err(|e| row(e.to_string()))?;
        let joints = if c.joints.is_empty() {
            None
        } else {
            let mut j = Vec::with_capacity(c.joints.len());
            for (n, i) in &c.joints {
                j.push(value(Some(*i), &format!("j{n}"), 0.0)?);
            }
            Some(j)
        };
        out.push(TrajectorySample {
            sample: TimedPose { t, pose },
            joints,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_columns_in_any_order_with_defaults() {
        let text = "# a comment\ny, t, x, j2, j1\n2, 0.0, 1, 20, 10\n\n3, 0.1, 1.5, 21, 11\n";
        let s = parse_trajectory(text).unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(s[1].sample.t, 0.1);
        assert_eq!(s[1].sample.pose.position().y, 3.0);
        assert_eq!(s[1].sample.pose.position().z, 0.0);
        assert_eq!(s[0].joints.as_deref(), Some(&[10.0, 20.0][..]));
    }

    #[test]
    fn names_what_is_wrong() {
        let err = |t: &str| parse_trajectory(t).unwrap_err().to_string();
        assert!(err("x,y\n1,2\n").contains("\"t\""));
        assert!(err("t,x,y,speed\n0,1,2,3\n").contains("speed"));
        assert!(err("t,x,y,qw\n0,1,2,1\n").contains("quaternion"));
        assert!(err("t,x,y,j2\n0,1,2,3\n").contains("j1 to jN"));
        assert!(err("t,x,y\n0,1,2\n0.1,nan,2\n").contains("line 3"));
        assert!(err("t,x,y,qw,qx,qy,qz\n0,1,2,2,0,0,0\n").contains("quaternion norm"));
        assert!(
            err("t,x,y\n0,1,2\n0.1,1,-2e5\n")
                .contains("line 3: y = -200000.0 is outside ±100000 mm")
        );
        assert!(err("t,x,y\n0,1\n").contains("CSV"));
    }
}

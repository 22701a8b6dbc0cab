//! ROS 2 bags in SQLite (`.db3`, rosbag2's `sqlite3` storage), read within
//! bounds: only from tables, and within a budget of SQLite steps.

use std::collections::BTreeMap;
use std::path::Path;

use super::{BagError, BagItem, Reading, Ros2};

/// SQLite steps (virtual machine instructions) a `.db3` may take per byte of
/// its file, for all its statements together: reading and sorting a real bag
/// takes a few per byte.
const SQLITE_STEPS_PER_BYTE: u64 = 200;
/// Steps any `.db3` may take, however small.
const SQLITE_MIN_STEPS: u64 = 50_000_000;
/// Steps between two looks of the progress handler.
const SQLITE_STEPS_PER_CALL: u64 = 10_000;

/// A ROS 2 bag in SQLite (rosbag2's `sqlite3` storage: tables `topics` and
/// `messages`, CDR messages), read in the order `ros2 bag play` plays it
/// (by timestamp, then as written). A database that fails after some
/// messages is read up to there, the damage named.
pub(super) fn read<F: FnMut(BagItem)>(path: &Path, r: &mut Reading<'_, F>) -> Result<(), BagError> {
    use rusqlite::{Connection, OpenFlags, OptionalExtension};
    let format = |e: rusqlite::Error| match e {
        rusqlite::Error::SqliteFailure(f, _) if f.code == rusqlite::ErrorCode::OperationInterrupted => {
            BagError::Format(
                "an SQLite database whose reading did not end within the steps a file of its size needs (a hostile or \
             damaged database)"
                    .into(),
            )
        }
        e => BagError::Format(format!("an SQLite database, but it cannot be read as a ROS 2 bag: {e}")),
    };
    let flags = OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX;
    let db = Connection::open_with_flags(path, flags).map_err(format)?;
    // Bounded: a hostile file's views (a recursive one never ends) are not
    // read, and no statement runs for more SQLite steps than a file of this
    // size can need.
    let budget = std::fs::metadata(path)?.len().saturating_mul(SQLITE_STEPS_PER_BYTE).max(SQLITE_MIN_STEPS);
    let mut steps = 0u64;
    db.progress_handler(
        SQLITE_STEPS_PER_CALL as i32,
        Some(move || {
            steps += SQLITE_STEPS_PER_CALL;
            steps > budget
        }),
    );
    for table in ["topics", "messages"] {
        let kind: Option<String> = db
            .query_row("SELECT type FROM sqlite_master WHERE name = ?1", [table], |row| row.get(0))
            .optional()
            .map_err(format)?;
        match kind.as_deref() {
            Some("table") => {}
            Some(other) => {
                return Err(BagError::Format(format!(
                    "an SQLite database whose {table:?} is a {other}, not a table: not a ROS 2 bag (rosbag2 writes tables)"
                )));
            }
            None => {
                return Err(BagError::Format(format!("an SQLite database without a {table:?} table: not a ROS 2 bag")));
            }
        }
    }
    let mut topics =
        db.prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id").map_err(format)?;
    let rows = topics
        .query_map([], |row| Ok((row.get::<_, i64>(0)?, row.get::<_, String>(1)?, row.get(2)?, row.get(3)?)))
        .map_err(format)?;
    let mut names = BTreeMap::new();
    for row in rows {
        let (id, name, ty, serialization): (i64, String, String, String) = row.map_err(format)?;
        let ty = if serialization == "cdr" { ty } else { format!("{serialization} message") };
        r.topic(&name, &ty)?;
        names.insert(id, name);
    }
    let mut messages = db.prepare("SELECT topic_id, data FROM messages ORDER BY timestamp, id").map_err(format)?;
    let mut rows = messages.query([]).map_err(format)?;
    loop {
        let message = match rows.next() {
            Ok(None) => return Ok(()),
            Ok(Some(row)) => row.get::<_, i64>(0).and_then(|id| Ok((id, row.get_ref(1)?.as_blob()?))),
            Err(e) => Err(e),
        };
        match message {
            Ok((id, data)) => match names.get(&id) {
                Some(name) => r.message::<Ros2>(name, data),
                None => r.t.position += 1,
            },
            Err(e) if r.t.position == 0 => return Err(format(e)),
            Err(e) => {
                r.t.summary.damage.get_or_insert(format!("after message {}: {}", r.t.position, format(e)));
                return Ok(());
            }
        }
    }
}

//! Who may touch fusiond's shared memory: only the user the processes run as.
//!
//! iceoryx2 0.10 creates every shared-memory segment, socket and file of a
//! service with owner-only permissions (0600, directories 0750), with two gaps
//! this module closes for every fusion process, before its node is created
//! (`service::create_node`):
//!
//! - **The node-id counter** of a domain (`/dev/shm/<prefix>…_node.<version>.global_mgmt`),
//!   which every new node increments, is created for everyone (0666). Another user
//!   who truncated it made every new fusion process hang. [`OwnerOnly`], the
//!   persistent storage of `transport::Ipc`, creates it 0600, repairs one
//!   of this user's that is wider, and refuses one that belongs to another user
//!   (named in the error) instead of waiting on it.
//! - **The root directory** (`/tmp/iceoryx2`, the services' static configs, node
//!   records and event sockets) is made by whoever comes first, with whatever
//!   umask. [`check_root_directory`] creates it 0700 when it is missing and
//!   refuses one that another user owns or that others may write to.
//!
//! A group cannot be given access: iceoryx2 0.10 makes each segment 0600 unless
//! built with its `dev_permissions` feature, which opens every file to everyone.
//! So fusiond, its sensors and its readers run as one user.

use core::fmt::Debug;
use core::ptr::NonNull;
use core::time::Duration;
use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use iceoryx2::config::Config;
use iceoryx2_bb_elementary_traits::testing::abandonable::Abandonable;
use iceoryx2_bb_elementary_traits::zero_copy_send::ZeroCopySend;
use iceoryx2_bb_memory::bump_allocator::BumpAllocator;
use iceoryx2_bb_posix::file::AccessMode;
use iceoryx2_cal::dynamic_storage::recommended::PersistentIpc;
use iceoryx2_cal::dynamic_storage::{
    DynamicStorage, DynamicStorageBuilder, DynamicStorageCreateError, DynamicStorageOpenError,
    DynamicStorageOpenOrCreateError,
};
use iceoryx2_cal::named_concept::{FileName, Path as IoxPath};
use iceoryx2_cal::named_concept::{
    NamedConcept, NamedConceptBuilder, NamedConceptConfiguration, NamedConceptDoesExistError, NamedConceptListError,
    NamedConceptMgmt, NamedConceptPathHintRemoveError, NamedConceptRemoveError,
};

/// Where POSIX shared memory lives.
const SHM_DIR: &str = "/dev/shm";

/// Why the last persistent segment was refused, for `service::create_node`
/// to report (iceoryx2 turns the refusal into `UnableToGenerateUniqueNodeId`).
static REFUSED: Mutex<Option<String>> = Mutex::new(None);

/// Takes the reason the last persistent segment was refused, if one was.
pub fn take_refusal() -> Option<String> {
    REFUSED.lock().map(|mut r| r.take()).unwrap_or(None)
}

/// The effective user id of this process.
pub fn euid() -> u32 {
    rustix::process::geteuid().as_raw()
}

/// Checks a file or directory this user's fusion processes rely on: it must be
/// this user's (not a link), with none of the permission bits of `closed`
/// (0o022: no one else may write; 0o077: no one else may read or write).
/// Returns why not.
fn check_owned(path: &Path, what: &str, closed: u32) -> Result<(), String> {
    let meta = std::fs::symlink_metadata(path).map_err(|e| format!("{what} {}: {e}", path.display()))?;
    let me = euid();
    if meta.file_type().is_symlink() {
        return Err(format!("{what} {} is a symbolic link; fusiond uses only its own files", path.display()));
    }
    if meta.uid() != me {
        return Err(format!(
            "{what} {} belongs to uid {}, but this process runs as uid {me}: another user created it. fusiond, its \
             sensors and its readers must run as one user; remove it (as root) or choose another iceoryx2 domain \
             (FUSION_ICEORYX_DOMAIN)",
            path.display(),
            meta.uid()
        ));
    }
    if meta.mode() & closed != 0 {
        return Err(format!(
            "{what} {} is open to other users (mode {:o}); close it to all but its owner",
            path.display(),
            meta.mode() & 0o7777
        ));
    }
    Ok(())
}

/// Checks iceoryx2's root directory of `config` (see the module docs), creating
/// it (mode 0700) when it does not exist.
pub fn check_root_directory(config: &Config) -> Result<(), String> {
    let root = PathBuf::from(config.global.root_path().to_string());
    match std::fs::symlink_metadata(&root) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            match std::fs::DirBuilder::new().mode(0o700).create(&root) {
                Ok(()) => {}
                // Another process of this user made it just now: checked below.
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
                Err(e) => return Err(format!("cannot create iceoryx2's directory {}: {e}", root.display())),
            }
        }
        Err(e) => return Err(format!("iceoryx2's directory {}: {e}", root.display())),
        Ok(_) => {}
    }
    check_owned(&root, "iceoryx2's directory", 0o022)
}

/// iceoryx2's recommended persistent storage (POSIX shared memory), but only
/// for this user: global access is never granted, and an existing segment is
/// checked before it is opened (see the module docs).
#[derive(Debug)]
pub struct OwnerOnly<T: Send + Sync + Debug + ZeroCopySend + 'static>(PersistentIpc<T>);

/// The builder of [`OwnerOnly`]: iceoryx2's, with the checks around it.
#[derive(Debug)]
pub struct OwnerOnlyBuilder<'b, T: Send + Sync + Debug + ZeroCopySend + 'static> {
    inner: <PersistentIpc<T> as DynamicStorage<T>>::Builder<'b>,
    name: FileName,
    config: <PersistentIpc<T> as NamedConceptMgmt>::Configuration,
}

impl<T: Send + Sync + Debug + ZeroCopySend + 'static> OwnerOnlyBuilder<'_, T> {
    /// The segment's file in `/dev/shm`.
    fn path(&self) -> PathBuf {
        Path::new(SHM_DIR).join(self.config.path_for(&self.name).file_name().to_string())
    }

    /// An existing segment must be this user's; one of this user's that others
    /// may read or write is narrowed to 0600 first.
    fn check_existing(&self) -> Result<(), ()> {
        let path = self.path();
        let Ok(meta) = std::fs::symlink_metadata(&path) else { return Ok(()) };
        if meta.uid() == euid() && !meta.file_type().is_symlink() && meta.mode() & 0o077 != 0 {
            let _ = std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600));
        }
        check_owned(&path, "iceoryx2's shared memory", 0o077).map_err(|reason| {
            if let Ok(mut r) = REFUSED.lock() {
                *r = Some(reason);
            }
        })
    }
}

impl<'b, T: Send + Sync + Debug + ZeroCopySend + 'static> NamedConceptBuilder<OwnerOnly<T>>
    for OwnerOnlyBuilder<'b, T>
{
    fn new(name: &FileName) -> Self {
        Self {
            inner: <<PersistentIpc<T> as DynamicStorage<T>>::Builder<'b> as NamedConceptBuilder<PersistentIpc<T>>>::new(
                name,
            ),
            name: *name,
            config: Default::default(),
        }
    }

    fn config(mut self, config: &<OwnerOnly<T> as NamedConceptMgmt>::Configuration) -> Self {
        self.config = config.clone();
        self.inner = self.inner.config(config);
        self
    }
}

impl<'b, T: Send + Sync + Debug + ZeroCopySend + 'static> DynamicStorageBuilder<'b, T, OwnerOnly<T>>
    for OwnerOnlyBuilder<'b, T>
{
    fn has_ownership(mut self, value: bool) -> Self {
        self.inner = self.inner.has_ownership(value);
        self
    }

    /// Never granted: the segment stays this user's alone.
    fn enable_global_access(mut self, _value: bool) -> Self {
        self.inner = self.inner.enable_global_access(false);
        self
    }

    fn supplementary_size(mut self, value: usize) -> Self {
        self.inner = self.inner.supplementary_size(value);
        self
    }

    fn timeout(mut self, value: Duration) -> Self {
        self.inner = self.inner.timeout(value);
        self
    }

    fn initializer<F: FnMut(&mut core::mem::MaybeUninit<T>, &mut BumpAllocator) -> bool + 'b>(
        mut self,
        value: F,
    ) -> Self {
        self.inner = self.inner.initializer(value);
        self
    }

    fn create(self) -> Result<OwnerOnly<T>, DynamicStorageCreateError> {
        self.inner.create().map(OwnerOnly)
    }

    fn open(self, access_mode: AccessMode) -> Result<OwnerOnly<T>, DynamicStorageOpenError> {
        self.check_existing().map_err(|()| DynamicStorageOpenError::InternalError)?;
        self.inner.open(access_mode).map(OwnerOnly)
    }

    fn open_or_create(self) -> Result<OwnerOnly<T>, DynamicStorageOpenOrCreateError> {
        self.check_existing().map_err(|()| {
            DynamicStorageOpenOrCreateError::DynamicStorageOpenError(DynamicStorageOpenError::InternalError)
        })?;
        self.inner.open_or_create().map(OwnerOnly)
    }
}

impl<T: Send + Sync + Debug + ZeroCopySend + 'static> NamedConcept for OwnerOnly<T> {
    fn name(&self) -> &FileName {
        self.0.name()
    }
}

impl<T: Send + Sync + Debug + ZeroCopySend + 'static> NamedConceptMgmt for OwnerOnly<T> {
    type Configuration = <PersistentIpc<T> as NamedConceptMgmt>::Configuration;

    unsafe fn remove_cfg(name: &FileName, cfg: &Self::Configuration) -> Result<bool, NamedConceptRemoveError> {
        // SAFETY: the caller's contract is the same as the wrapped storage's.
        unsafe { PersistentIpc::<T>::remove_cfg(name, cfg) }
    }

    fn does_exist_cfg(name: &FileName, cfg: &Self::Configuration) -> Result<bool, NamedConceptDoesExistError> {
        PersistentIpc::<T>::does_exist_cfg(name, cfg)
    }

    fn list_cfg(cfg: &Self::Configuration) -> Result<Vec<FileName>, NamedConceptListError> {
        PersistentIpc::<T>::list_cfg(cfg)
    }

    fn remove_path_hint(value: &IoxPath) -> Result<(), NamedConceptPathHintRemoveError> {
        PersistentIpc::<T>::remove_path_hint(value)
    }
}

impl<T: Send + Sync + Debug + ZeroCopySend + 'static> Abandonable for OwnerOnly<T> {
    unsafe fn abandon_in_place(this: NonNull<Self>) {
        // SAFETY: `this` points to a valid `OwnerOnly`, so to its one field.
        unsafe { PersistentIpc::<T>::abandon_in_place(NonNull::from_mut(&mut (*this.as_ptr()).0)) }
    }
}

impl<T: Send + Sync + Debug + ZeroCopySend + 'static> DynamicStorage<T> for OwnerOnly<T> {
    type Builder<'b> = OwnerOnlyBuilder<'b, T>;

    fn does_support_persistency() -> bool {
        PersistentIpc::<T>::does_support_persistency()
    }

    fn has_ownership(&self) -> bool {
        self.0.has_ownership()
    }

    fn release_ownership(&self) {
        self.0.release_ownership()
    }

    fn acquire_ownership(&self) {
        self.0.acquire_ownership()
    }

    fn get(&self) -> &T {
        self.0.get()
    }

    unsafe fn __internal_set_type_name_in_config(config: &mut Self::Configuration, type_name: &str) {
        // SAFETY: forwarded unchanged.
        unsafe { PersistentIpc::<T>::__internal_set_type_name_in_config(config, type_name) }
    }
}

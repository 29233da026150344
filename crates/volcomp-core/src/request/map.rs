//! The error map a job compensates or simulates with, named by its file,
//! and what the controller compensates itself.

use super::option::OptionError;
use crate::io::controllers::{self, ControllerReadError};
use crate::io::provenance::{sha256_hex, ProgramHeader};
use crate::io::{load_model, LoadOptions};
use crate::model::controller::{ControllerApplies, ControllerResidual};
use crate::model::ErrorModel;
use crate::Error;
use std::path::PathBuf;

request! {
    /// The map file and what the controller compensates itself.
    pub struct MapRequest {}
    /// The options of [`MapRequest`].
    pub const MAP_OPTIONS, unknown "map";

    /// The map file: axis tables (CSV) or a model (TOML).
    map: Option<PathBuf> = None, Path.value("MAP").required(),
        "Error map: axis-table CSV (docs/design.md, \"The axis-table map\") or a TOML model (the 21-component kinematic model of docs/kinematic.md, evaluated at each line's tool).";

    /// Hold positions outside the map at its ends.
    clamp: bool = false, Switch,
        "Clamp positions outside the map's range to its end instead of refusing.";

    /// A table the controller applies itself.
    controller: Option<PathBuf> = None, Path.value("FILE"),
        "A compensation table the controller applies itself (exported or read from it: Siemens EEC, Heidenhain .COM/.CMA, Klipper, Marlin; docs/controllers.md): only the rest of the map is compensated.";

    /// What the controller compensates from this very map (`positioning`).
    controller_compensates: Option<String> = None, Choice.value("WHAT").choices(&[(
        "positioning",
        "The positioning errors E_XX, E_YY, E_ZZ (pitch/leadscrew compensation)",
    )]),
        "What the controller compensates from this very map: `positioning` (its pitch tables hold the map's E_XX, E_YY, E_ZZ).";
}

fn controller_error(e: ControllerReadError) -> Error {
    match e {
        ControllerReadError::Io { path, source } => Error::io(path, source),
        ControllerReadError::Format(f) => Error::MapFile(f),
    }
}

impl MapRequest {
    /// The map file (refused when none was named).
    pub fn path(&self) -> Result<&std::path::Path, OptionError> {
        self.map
            .as_deref()
            .ok_or_else(|| OptionError::new("map", "is required: name the error map file"))
    }

    /// The model to compensate: the map, or with a controller that
    /// compensates part of it, the residual it leaves
    /// ([`ControllerResidual`]).
    pub fn load(&self) -> Result<Box<dyn ErrorModel>, Error> {
        Ok(self.load_noting()?.0)
    }

    /// [`MapRequest::load`], with what reading the controller's files
    /// assumed or found the controller ignoring (for the front end to show).
    pub fn load_noting(&self) -> Result<(Box<dyn ErrorModel>, Vec<String>), Error> {
        let controller = self.controller_applies()?;
        let map = load_model(self.path()?, &LoadOptions { clamp: self.clamp })?.into_model();
        Ok(match controller {
            Some(controller) => {
                let notes = controller.notes().to_vec();
                (Box::new(ControllerResidual { map, controller }), notes)
            }
            None => (map, Vec::new()),
        })
    }

    fn controller_applies(&self) -> Result<Option<ControllerApplies>, Error> {
        match (&self.controller, self.controller_compensates.as_deref()) {
            (Some(_), Some(_)) => Err(OptionError::new(
                "controller",
                "cannot be given with {controller_compensates}: name the controller's table, or say what it compensates from this map",
            )
            .into()),
            (Some(file), None) => Ok(Some(
                controllers::read_applies(file).map_err(controller_error)?,
            )),
            (None, Some(what)) => {
                let info = &MAP_OPTIONS[3];
                info.choice(what)
                    .map_err(|p| OptionError::new("controller_compensates", p))?;
                Ok(Some(ControllerApplies::MapPositioning))
            }
            (None, None) => Ok(None),
        }
    }

    /// Adds what the controller compensates to a program's header: its
    /// table (name and SHA-256), or what it compensates from this map.
    pub fn note(&self, header: &mut ProgramHeader) -> Result<(), Error> {
        if let Some(file) = &self.controller {
            let bytes = crate::io::inputs::read(file, "the controller file")
                .map_err(|e| Error::io(file, e))?;
            header.files.push((
                "ctrl".into(),
                crate::compensate::file_name(file),
                sha256_hex(&bytes),
            ));
        }
        if self.controller_compensates.is_some() {
            header
                .options
                .push_str("; the controller compensates the positioning errors");
        }
        Ok(())
    }
}

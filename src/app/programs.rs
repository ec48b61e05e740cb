//! Programs of a cell: create, list, read.

use super::error::AppError;
use super::rows::program;
use super::{App, Result, check_name};
use crate::api::{CreateProgram, Program};

impl App {
    pub async fn create_program(&self, cell_id: i64, input: CreateProgram) -> Result<Program> {
        check_name("program name", &input.name)?;
        self.cell_row(cell_id).await?;
        let row = self
            .store
            .insert_program(cell_id, input.name.trim())
            .await
            .map_err(|e| match AppError::from(e) {
                AppError::Conflict(_) => AppError::Exists(format!(
                    "cell {cell_id} already has a program named {:?}",
                    input.name.trim()
                )),
                other => other,
            })?;
        Ok(program(row))
    }

    pub async fn programs(&self, cell_id: i64) -> Result<Vec<Program>> {
        self.cell_row(cell_id).await?;
        Ok(self
            .store
            .programs(cell_id)
            .await?
            .into_iter()
            .map(program)
            .collect())
    }

    pub async fn get_program(&self, id: i64) -> Result<Program> {
        Ok(program(self.program_row(id).await?))
    }
}

//! A command's client of a running `kerf serve` (its HTTP API, [`super`]).

use std::time::Duration;

/// What went wrong asking the station.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// Nothing answered at the address.
    #[error("{url}: no kerf serve answers there ({message})")]
    Unreachable {
        /// The station's address.
        url: String,
        /// Why.
        message: String,
    },
    /// The station or the machine refused the request.
    #[error("{words}")]
    Refused {
        /// The HTTP status.
        status: u16,
        /// Why, in words.
        words: String,
    },
}

/// The station at `url` (`http://127.0.0.1:8080`).
pub struct Client {
    agent: ureq::Agent,
    url: String,
}

impl Client {
    /// A client of the station at `url` (the scheme may be left out).
    pub fn new(url: &str) -> Self {
        let url = url.trim_end_matches('/');
        let url = if url.contains("://") {
            url.to_owned()
        } else {
            format!("http://{url}")
        };
        let agent = ureq::Agent::config_builder()
            .http_status_as_error(false)
            // Longer than the station's own wait for the machine.
            .timeout_global(Some(super::station::ANSWER_WAIT + Duration::from_secs(5)))
            .build()
            .into();
        Client { agent, url }
    }

    /// `GET path`, its JSON.
    pub fn get(&self, path: &str) -> Result<serde_json::Value, ClientError> {
        self.answer(self.agent.get(format!("{}{path}", self.url)).call())
    }

    /// `POST path` with a JSON body, its JSON.
    pub fn post(
        &self,
        path: &str,
        body: &serde_json::Value,
    ) -> Result<serde_json::Value, ClientError> {
        self.answer(
            self.agent
                .post(format!("{}{path}", self.url))
                .send_json(body),
        )
    }

    /// `POST path` with `bytes` as the body, its JSON.
    pub fn post_bytes(&self, path: &str, bytes: &[u8]) -> Result<serde_json::Value, ClientError> {
        self.answer(self.agent.post(format!("{}{path}", self.url)).send(bytes))
    }

    /// The station's server-sent events, line by line (`event: …`, `data: {…}`).
    pub fn stream(&self) -> Result<impl std::io::BufRead, ClientError> {
        let response = ureq::Agent::config_builder()
            .http_status_as_error(true)
            .build()
            .new_agent()
            .get(format!("{}/api/stream", self.url))
            .call()
            .map_err(|e| ClientError::Unreachable {
                url: self.url.clone(),
                message: e.to_string(),
            })?;
        Ok(std::io::BufReader::new(response.into_body().into_reader()))
    }

    fn answer(
        &self,
        sent: Result<ureq::http::Response<ureq::Body>, ureq::Error>,
    ) -> Result<serde_json::Value, ClientError> {
        let mut response = sent.map_err(|e| ClientError::Unreachable {
            url: self.url.clone(),
            message: e.to_string(),
        })?;
        let status = response.status().as_u16();
        let body: serde_json::Value = response
            .body_mut()
            .read_json()
            .unwrap_or(serde_json::Value::Null);
        if (200..300).contains(&status) {
            return Ok(body);
        }
        Err(ClientError::Refused {
            status,
            words: body["error"]
                .as_str()
                .map_or_else(|| format!("the station answered {status}"), str::to_owned),
        })
    }
}

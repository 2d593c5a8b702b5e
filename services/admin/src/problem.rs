//! Errors as RFC 9457 problem details (`application/problem+json`), and a JSON
//! body extractor whose rejections become problems naming the field.

use axum::Json;
use axum::extract::rejection::JsonRejection;
use axum::extract::{FromRequest, Request};
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use serde::de::DeserializeOwned;
use trafficmesh_bus::BusError;
use utoipa::ToSchema;

#[derive(Debug, Serialize, ToSchema)]
pub struct Problem {
    /// A URI naming the kind of problem (`about:blank` when the status says it all).
    #[serde(rename = "type")]
    pub kind: &'static str,
    pub title: String,
    pub status: u16,
    pub detail: String,
    /// Every problem found, each naming its field, when there are several.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub problems: Vec<String>,
}

impl Problem {
    pub fn new(status: StatusCode, detail: impl Into<String>) -> Problem {
        Problem {
            kind: "about:blank",
            title: status.canonical_reason().unwrap_or("error").to_string(),
            status: status.as_u16(),
            detail: detail.into(),
            problems: Vec::new(),
        }
    }

    pub fn with_problems(mut self, problems: Vec<String>) -> Problem {
        self.problems = problems;
        self
    }

    pub fn not_found(detail: impl Into<String>) -> Problem {
        Problem::new(StatusCode::NOT_FOUND, detail)
    }

    pub fn unprocessable(detail: impl Into<String>) -> Problem {
        Problem::new(StatusCode::UNPROCESSABLE_ENTITY, detail)
    }
}

impl IntoResponse for Problem {
    fn into_response(self) -> Response {
        let status = StatusCode::from_u16(self.status).unwrap_or(StatusCode::INTERNAL_SERVER_ERROR);
        let mut response = (status, Json(&self)).into_response();
        response.headers_mut().insert(
            header::CONTENT_TYPE,
            HeaderValue::from_static("application/problem+json"),
        );
        response
    }
}

/// A service's refusal is the client's problem (422, with the service's list);
/// a silent or unreachable service is a 503.
impl From<BusError> for Problem {
    fn from(e: BusError) -> Problem {
        match e {
            BusError::Remote {
                ref message,
                ref problems,
                ..
            } => Problem::unprocessable(message.clone()).with_problems(problems.clone()),
            BusError::NoAnswer { .. } => {
                Problem::new(StatusCode::SERVICE_UNAVAILABLE, e.to_string())
            }
            _ => Problem::new(StatusCode::BAD_GATEWAY, e.to_string()),
        }
    }
}

/// `Json<T>` whose rejections are problems: 415 without a JSON content type,
/// 400 for malformed JSON, 422 naming the field for a wrong type or a missing
/// field, 413 for a body over the limit.
pub struct ApiJson<T>(pub T);

impl<S, T> FromRequest<S> for ApiJson<T>
where
    T: DeserializeOwned,
    S: Send + Sync,
{
    type Rejection = Problem;

    async fn from_request(req: Request, state: &S) -> Result<Self, Self::Rejection> {
        match Json::<T>::from_request(req, state).await {
            Ok(Json(v)) => Ok(ApiJson(v)),
            Err(rejection) => Err(rejection_problem(rejection)),
        }
    }
}

fn rejection_problem(rejection: JsonRejection) -> Problem {
    let status = rejection.status();
    // axum's text for data errors carries the path of the field (serde_path_to_error).
    let detail = match &rejection {
        JsonRejection::JsonDataError(e) => std::error::Error::source(e)
            .map(|s| s.to_string())
            .unwrap_or_else(|| e.body_text()),
        JsonRejection::JsonSyntaxError(e) => std::error::Error::source(e)
            .map(|s| format!("malformed JSON: {s}"))
            .unwrap_or_else(|| e.body_text()),
        other => other.body_text(),
    };
    Problem::new(status, detail)
}

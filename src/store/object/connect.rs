//! Opening an object store: the S3 client from a URL and the `AWS_*`
//! settings, with its retries and timeouts, and the runtime the blocking
//! [`ViewStore`](super::super::ViewStore) calls run on.

use std::future::Future;
use std::sync::atomic::AtomicU64;
use std::sync::Arc;
use std::time::Duration;

use object_store::ObjectStore;

use super::{ObjectViewStore, REQUEST_TIMEOUT, RETRIES, RETRY_TIMEOUT};
use crate::store::{StoreError, ViewStore};

impl ObjectViewStore {
    /// Opens `s3://BUCKET/PREFIX` with the endpoint, region and credentials
    /// of the standard AWS environment variables (`AWS_ENDPOINT_URL`,
    /// `AWS_REGION`, `AWS_ACCESS_KEY_ID`, `AWS_SECRET_ACCESS_KEY`,
    /// `AWS_ALLOW_HTTP=true` for a plain-HTTP endpoint), path-style
    /// requests unless `AWS_VIRTUAL_HOSTED_STYLE_REQUEST` says otherwise.
    /// Checks that the bucket answers.
    pub fn from_url(url: &str) -> Result<Self, StoreError> {
        Self::open(url, std::env::vars())
    }

    /// As [`Self::from_url`], with `AWS_*` settings from `vars` instead of
    /// the environment (tests run several servers in one process).
    pub fn open(url: &str, vars: impl IntoIterator<Item = (String, String)>) -> Result<Self, StoreError> {
        let rest = url.strip_prefix("s3://").ok_or_else(|| {
            StoreError::BadId(format!(
                "store {url:?} is not accepted; use s3://BUCKET or s3://BUCKET/PREFIX"
            ))
        })?;
        let (bucket, prefix) = rest.split_once('/').unwrap_or((rest, ""));
        if bucket.is_empty() {
            return Err(StoreError::BadId(format!("store {url:?} names no bucket")));
        }
        let retry = object_store::RetryConfig {
            backoff: object_store::BackoffConfig {
                init_backoff: Duration::from_millis(50),
                max_backoff: Duration::from_millis(500),
                base: 2.0,
            },
            max_retries: RETRIES,
            retry_timeout: RETRY_TIMEOUT,
        };
        let options = object_store::ClientOptions::new()
            .with_timeout(REQUEST_TIMEOUT)
            .with_connect_timeout(Duration::from_secs(1));
        // Options first: the AWS_* settings (AWS_ALLOW_HTTP among them)
        // refine them.
        let mut builder = object_store::aws::AmazonS3Builder::new()
            .with_retry(retry)
            .with_client_options(options);
        for (key, value) in vars {
            if key.starts_with("AWS_") {
                if let Ok(k) = key.to_ascii_lowercase().parse() {
                    builder = builder.with_config(k, value);
                }
            }
        }
        let s3 = builder
            .with_bucket_name(bucket)
            .build()
            .map_err(|e| StoreError::BadId(format!("store {url:?}: {e}")))?;
        let store = Self::new(Arc::new(s3), prefix, url)?;
        store.scenes().map_err(|e| match e {
            StoreError::Unavailable(m) => StoreError::Unavailable(format!("{url}: {m}")),
            other => other,
        })?;
        Ok(store)
    }

    /// Views under `prefix` of `store`; `name` names it in messages.
    pub fn new(store: Arc<dyn ObjectStore>, prefix: &str, name: &str) -> Result<Self, StoreError> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("dmesh-object-store")
            .enable_all()
            .build()?;
        let prefix = prefix.trim_matches('/');
        Ok(Self {
            store,
            prefix: if prefix.is_empty() {
                String::new()
            } else {
                format!("{prefix}/")
            },
            runtime: Some(runtime),
            counter: AtomicU64::new(0),
            puts: AtomicU64::new(0),
            name: name.to_string(),
        })
    }

    /// Runs `f` on the store's runtime. A thread inside another runtime
    /// (the server's blocking pool, an async test) may not block on a
    /// runtime itself, so there it runs on a short-lived scoped thread.
    pub(super) fn block_on<F>(&self, f: F) -> F::Output
    where
        F: Future + Send,
        F::Output: Send,
    {
        let Some(rt) = &self.runtime else {
            unreachable!("the runtime lives until drop")
        };
        if tokio::runtime::Handle::try_current().is_err() {
            return rt.block_on(f);
        }
        std::thread::scope(|s| {
            s.spawn(|| rt.block_on(f))
                .join()
                .unwrap_or_else(|p| std::panic::resume_unwind(p))
        })
    }
}

impl Drop for ObjectViewStore {
    fn drop(&mut self) {
        // Dropping a runtime may block, which an async caller must not.
        if let Some(rt) = self.runtime.take() {
            rt.shutdown_background();
        }
    }
}

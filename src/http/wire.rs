//! Problem bodies for the answers hyper writes itself.
//!
//! When a request head cannot be parsed (a malformed request line or header, a head past
//! hyper's buffer, a request target past its limit), hyper answers `400`, `431` or `414` on its
//! own, with `content-length: 0`, before any of our code sees a request. [`ProblemIo`] sits
//! between hyper and the socket, recognises such a bodiless answer as hyper writes it, and
//! writes a problem+json answer of the same status in its place, so that every error a client
//! gets from this server has a body that names the problem.

use super::AppError;
use axum::http::StatusCode;
use std::io;
use std::pin::Pin;
use std::task::{Context, Poll, ready};
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};

/// A connection's byte stream, with hyper's bodiless error answers replaced by problems.
pub struct ProblemIo<T> {
    inner: T,
    /// Bytes of a replacement answer not yet written, from `sent`.
    pending: Vec<u8>,
    sent: usize,
}

impl<T> ProblemIo<T> {
    pub fn new(inner: T) -> ProblemIo<T> {
        ProblemIo {
            inner,
            pending: Vec::new(),
            sent: 0,
        }
    }
}

/// The problem answer that stands for hyper's bodiless answer `head`, if `head` is one: a
/// whole response head of status 400, 414 or 431 with `content-length: 0`.
pub fn replacement(head: &[u8]) -> Option<Vec<u8>> {
    let status = [
        (&b"HTTP/1.1 400 "[..], StatusCode::BAD_REQUEST),
        (b"HTTP/1.1 414 ", StatusCode::URI_TOO_LONG),
        (
            b"HTTP/1.1 431 ",
            StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE,
        ),
    ]
    .into_iter()
    .find(|(p, _)| head.starts_with(p))?
    .1;
    let lower = head.to_ascii_lowercase();
    let end = lower.windows(4).position(|w| w == b"\r\n\r\n")?;
    // The whole head and nothing after it (hyper's error answers have no body), with an empty
    // body declared.
    if end + 4 != head.len()
        || !lower[..end + 2]
            .windows(20)
            .any(|w| w == b"\r\ncontent-length: 0\r")
    {
        return None;
    }
    let p = match status {
        StatusCode::URI_TOO_LONG => AppError::new(
            status,
            "uri-too-long",
            "URI too long",
            "the request target is longer than the server reads",
        ),
        StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE => AppError::new(
            status,
            "headers-too-large",
            "Request header fields too large",
            format!(
                "the request head is larger than the server reads (at most {} header fields \
                 of {} bytes are accepted)",
                super::server::MAX_HEADERS,
                super::server::MAX_HEADER_BYTES
            ),
        ),
        _ => AppError::new(
            status,
            "malformed-request",
            "Malformed request",
            "the request line or a header field is not valid HTTP/1.1",
        ),
    };
    let body = p.body().to_string();
    let mut out = format!(
        "HTTP/1.1 {} {}\r\ncontent-type: application/problem+json\r\ncontent-length: {}\r\n\
         connection: close\r\n\r\n",
        status.as_u16(),
        status.canonical_reason().unwrap_or(""),
        body.len()
    )
    .into_bytes();
    out.extend_from_slice(body.as_bytes());
    Some(out)
}

impl<T: AsyncWrite + Unpin> ProblemIo<T> {
    /// Writes what is left of a replacement answer; Ready once it is all out.
    fn poll_pending(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        while self.sent < self.pending.len() {
            let n = ready!(Pin::new(&mut self.inner).poll_write(cx, &self.pending[self.sent..]))?;
            if n == 0 {
                return Poll::Ready(Err(io::ErrorKind::WriteZero.into()));
            }
            self.sent += n;
        }
        Poll::Ready(Ok(()))
    }

    /// Takes `head` as written when it is one of hyper's bodiless error answers.
    fn substitute(&mut self, head: &[u8]) -> bool {
        match replacement(head) {
            Some(r) => {
                self.pending = r;
                self.sent = 0;
                true
            }
            None => false,
        }
    }
}

impl<T: AsyncRead + Unpin> AsyncRead for ProblemIo<T> {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_read(cx, buf)
    }
}

impl<T: AsyncWrite + Unpin> AsyncWrite for ProblemIo<T> {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        ready!(self.poll_pending(cx))?;
        if self.substitute(buf) {
            // Claimed as written; the replacement goes out on the next write, flush or
            // shutdown.
            let _ = self.poll_pending(cx)?;
            return Poll::Ready(Ok(buf.len()));
        }
        Pin::new(&mut self.inner).poll_write(cx, buf)
    }

    fn poll_write_vectored(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[io::IoSlice<'_>],
    ) -> Poll<io::Result<usize>> {
        ready!(self.poll_pending(cx))?;
        let mut full = bufs.iter().filter(|b| !b.is_empty());
        if let (Some(only), None) = (full.next(), full.next())
            && self.substitute(only)
        {
            let _ = self.poll_pending(cx)?;
            return Poll::Ready(Ok(only.len()));
        }
        Pin::new(&mut self.inner).poll_write_vectored(cx, bufs)
    }

    fn is_write_vectored(&self) -> bool {
        self.inner.is_write_vectored()
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        ready!(self.poll_pending(cx))?;
        Pin::new(&mut self.inner).poll_flush(cx)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        ready!(self.poll_pending(cx))?;
        Pin::new(&mut self.inner).poll_shutdown(cx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_bodiless_error_heads_are_replaced() {
        let head = b"HTTP/1.1 400 Bad Request\r\ncontent-length: 0\r\ndate: x\r\n\r\n";
        let r = String::from_utf8(replacement(head).unwrap()).unwrap();
        assert!(r.starts_with("HTTP/1.1 400 Bad Request\r\n"), "{r}");
        let (h, body) = r.split_once("\r\n\r\n").unwrap();
        assert!(h.contains("content-type: application/problem+json"), "{h}");
        assert!(
            h.contains(&format!("content-length: {}", body.len())),
            "{h}"
        );
        let p: serde_json::Value = serde_json::from_str(body).unwrap();
        assert_eq!(p["status"], 400);
        assert!(p["type"].as_str().unwrap().ends_with("malformed-request"));
        for (code, kind) in [(414, "uri-too-long"), (431, "headers-too-large")] {
            let head = format!("HTTP/1.1 {code} X\r\ncontent-length: 0\r\n\r\n");
            let r = String::from_utf8(replacement(head.as_bytes()).unwrap()).unwrap();
            assert!(r.starts_with(&format!("HTTP/1.1 {code} ")), "{r}");
            assert!(r.contains(kind), "{r}");
        }
        // Our own answers have bodies; other statuses, bodies after the head, and partial
        // heads pass through unchanged.
        for keep in [
            &b"HTTP/1.1 400 Bad Request\r\ncontent-length: 12\r\n\r\n"[..],
            b"HTTP/1.1 400 Bad Request\r\ncontent-length: 0\r\n\r\nHTTP/1.1 200 OK\r\n",
            b"HTTP/1.1 400 Bad Request\r\ncontent-length: 0\r\n",
            b"HTTP/1.1 404 Not Found\r\ncontent-length: 0\r\n\r\n",
            b"HTTP/1.1 200 OK\r\ncontent-length: 0\r\n\r\n",
        ] {
            assert!(
                replacement(keep).is_none(),
                "{}",
                String::from_utf8_lossy(keep)
            );
        }
    }
}

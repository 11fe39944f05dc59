//! A connection's byte stream as the server writes it: problem bodies for the answers hyper
//! writes itself, and a lingering close.
//!
//! When a request head cannot be parsed (a malformed request line or header, a head past
//! hyper's buffer, a request target past its limit), hyper answers `400`, `431` or `414` on its
//! own, with `content-length: 0`, before any of our code sees a request. [`ProblemIo`] sits
//! between hyper and the socket, recognises such a bodiless answer as hyper writes it, and
//! writes a problem+json answer of the same status in its place, so that every error a client
//! gets from this server has a body that names the problem.
//!
//! When hyper closes a connection whose request body was not read (a `413` from the head
//! alone, a `401` before an upload), closing at once with the client's bytes unread makes the
//! kernel reset the connection, and the client may lose the answer on its way. So the close
//! lingers: the write side is shut down (the answer is out, then a FIN), and what the client
//! still sends is read and dropped until it closes, [`LINGER_BYTES`] have been read, or
//! [`LINGER`] has passed.

use super::AppError;
use axum::http::StatusCode;
use std::future::Future;
use std::io;
use std::pin::Pin;
use std::task::{Context, Poll, ready};
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};

/// Longest a closing connection reads what its client still sends.
pub const LINGER: std::time::Duration = std::time::Duration::from_secs(1);
/// Most bytes a closing connection reads and drops (the largest request body).
pub const LINGER_BYTES: usize = 64 << 20;

/// A connection's byte stream, with hyper's bodiless error answers replaced by problems and
/// a lingering close.
pub struct ProblemIo<T> {
    inner: T,
    /// Bytes of a replacement answer not yet written, from `sent`.
    pending: Vec<u8>,
    sent: usize,
    /// Once the close has begun: the write side shut down, the deadline, bytes drained.
    closing: Option<Closing>,
}

struct Closing {
    shut: bool,
    deadline: Pin<Box<tokio::time::Sleep>>,
    drained: usize,
}

impl<T> ProblemIo<T> {
    pub fn new(inner: T) -> ProblemIo<T> {
        ProblemIo {
            inner,
            pending: Vec::new(),
            sent: 0,
            closing: None,
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

impl<T: AsyncRead + AsyncWrite + Unpin> AsyncWrite for ProblemIo<T> {
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
        let this = &mut *self;
        let c = this.closing.get_or_insert_with(|| Closing {
            shut: false,
            deadline: Box::pin(tokio::time::sleep(LINGER)),
            drained: 0,
        });
        if !c.shut {
            ready!(Pin::new(&mut this.inner).poll_shutdown(cx))?;
            c.shut = true;
        }
        // Linger: drop what the client still sends until it closes, or enough.
        let mut scratch = [0u8; 16 << 10];
        while c.drained < LINGER_BYTES {
            let mut buf = ReadBuf::new(&mut scratch);
            match Pin::new(&mut this.inner).poll_read(cx, &mut buf) {
                Poll::Ready(Ok(())) if buf.filled().is_empty() => return Poll::Ready(Ok(())),
                Poll::Ready(Ok(())) => c.drained += buf.filled().len(),
                Poll::Ready(Err(_)) => return Poll::Ready(Ok(())),
                Poll::Pending => {
                    ready!(c.deadline.as_mut().poll(cx));
                    return Poll::Ready(Ok(()));
                }
            }
        }
        Poll::Ready(Ok(()))
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

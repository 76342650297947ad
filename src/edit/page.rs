//! The editor's page, built into the binary (it works offline: no CDN, no
//! third-party code).

/// A file of the page.
pub struct PageAsset {
    pub content_type: &'static str,
    pub body: &'static str,
}

/// The page's file at `url`, if it is one.
pub fn asset(url: &str) -> Option<PageAsset> {
    let (content_type, body) = match url {
        "/" | "/index.html" => ("text/html; charset=utf-8", include_str!("page/index.html")),
        "/editor.js" => ("text/javascript; charset=utf-8", include_str!("page/editor.js")),
        "/views.js" => ("text/javascript; charset=utf-8", include_str!("page/views.js")),
        "/editor.css" => ("text/css; charset=utf-8", include_str!("page/editor.css")),
        _ => return None,
    };
    Some(PageAsset { content_type, body })
}

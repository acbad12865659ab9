// Search on a site opened from disk. Material's search runs in a Web Worker, and browsers do
// not start a worker from a file:// page. Opened from disk, this runs the worker's script in a
// hidden iframe instead, with the same messages both ways; on a served site (http, https) it
// does nothing. Loaded before Material's bundle (mkdocs.yml, extra.polyfills: the file name
// holds "iframe-worker", so Material's offline plugin adds no shim from a CDN). The global
// IFrameWorker is the name Material's search worker looks for to know it runs in a frame.
(function () {
  "use strict";
  if (location.protocol !== "file:") {
    return;
  }

  class IFrameWorker extends EventTarget {
    constructor(url) {
      super();
      this.onmessage = null;
      this.onerror = null;
      this.pending = [];
      this.loaded = false;
      this.frame = document.createElement("iframe");
      this.frame.style.display = "none";
      this.frame.setAttribute("aria-hidden", "true");
      (document.body || document.documentElement).appendChild(this.frame);
      const scope = this.frame.contentWindow;
      // the worker's postMessage: to this object's listeners, later, as a worker's would arrive
      scope.postMessage = (data) => setTimeout(() => this.emit("message", data));
      const script = scope.document.createElement("script");
      script.src = new URL(url, location.href).href;
      script.onload = () => {
        this.loaded = true;
        this.pending.splice(0).forEach((data) => this.deliver(data));
      };
      script.onerror = () => this.emit("error", `cannot load the worker ${script.src}`);
      scope.document.head.appendChild(script);
    }

    emit(type, data) {
      const event = new MessageEvent(type, { data });
      this.dispatchEvent(event);
      const handler = type === "message" ? this.onmessage : this.onerror;
      if (typeof handler === "function") {
        handler.call(this, event);
      }
    }

    deliver(data) {
      const scope = this.frame.contentWindow;
      scope.dispatchEvent(new scope.MessageEvent("message", { data }));
    }

    postMessage(data) {
      if (this.loaded) {
        setTimeout(() => this.deliver(data));
      } else {
        this.pending.push(data);
      }
    }

    terminate() {
      this.frame.remove();
    }
  }

  window.IFrameWorker = IFrameWorker;
  window.Worker = IFrameWorker;
})();

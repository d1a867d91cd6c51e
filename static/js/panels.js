// The two side panels: collapsible, collapsed by default on narrow screens, and
// reported to the scene so framing keeps the robots in the part they leave free
// (and the canvas spans only that part).

const NARROW = '(max-width: 800px)';
const GAP_PX = 14; // panels sit this far from the window's edge

class Panels {

	constructor( root, onInsets ) {

		this.onInsets = onInsets; // (leftPx, rightPx, bottomPx) => void
		this.narrow = window.matchMedia( NARROW );
		this.panels = [ ...root.querySelectorAll( '.panel' ) ].map( ( panel ) => {

			const toggle = panel.querySelector( '.panel-toggle' );
			const entry = { panel, toggle };
			toggle.addEventListener( 'click', () => this.setOpen( entry, panel.classList.contains( 'collapsed' ) ) );
			return entry;

		} );
		this._onNarrow = () => this._defaults();
		this.narrow.addEventListener( 'change', this._onNarrow );
		this._observer = new ResizeObserver( () => this._report() );
		for ( const { panel } of this.panels ) this._observer.observe( panel );
		// On a narrow screen an open panel ends above the timeline bar, whose height
		// depends on how its rows wrap: keep that height in a CSS variable.
		this._bar = root.querySelector( '.timeline' );
		this._barObserver = new ResizeObserver( () => {

			this._barSpace();
			this._report();

		} );
		if ( this._bar ) this._barObserver.observe( this._bar );
		this._onResize = () => this._report(); // the bar is centred: whether it spans the free part depends on the width
		window.addEventListener( 'resize', this._onResize );
		this._defaults();

	}

	// Narrow screens start with both panels collapsed, so they never cover the robots.
	_defaults() {

		for ( const entry of this.panels ) this.setOpen( entry, ! this.narrow.matches );

	}

	setOpen( entry, open ) {

		const { panel, toggle } = entry;
		// A phone has room for one open panel: it spans the width and the others step
		// aside (their headers come back when it closes), so no panel covers another's buttons.
		if ( open && this.narrow.matches ) {

			for ( const other of this.panels ) if ( other !== entry ) this._set( other, false );

		}
		this._set( entry, open );
		const anyOpen = this.panels.some( ( e ) => ! e.panel.classList.contains( 'collapsed' ) );
		document.body.classList.toggle( 'panel-open', anyOpen && this.narrow.matches );
		this._report();

	}

	_set( entry, open ) {

		const { panel, toggle } = entry;
		panel.classList.toggle( 'collapsed', ! open );
		toggle.setAttribute( 'aria-expanded', String( open ) );
		const what = panel.getAttribute( 'aria-label' ) || 'panel';
		toggle.setAttribute( 'aria-label', `${open ? 'collapse' : 'expand'} ${what.toLowerCase()}` );
		toggle.textContent = open ? '−' : '+';

	}

	_barSpace() {

		const height = this._bar && ! this._bar.hidden ? this._bar.getBoundingClientRect().height : 0;
		document.documentElement.style.setProperty( '--timeline-space', `${Math.ceil( height )}px` );

	}

	_report() {

		if ( this.narrow.matches ) {

			this.onInsets( 0, 0 ); // panels float over the view; only their headers when collapsed
			return;

		}
		let left = 0;
		let right = 0;
		for ( const { panel } of this.panels ) {

			if ( panel.classList.contains( 'collapsed' ) ) continue;
			const width = panel.getBoundingClientRect().width + GAP_PX;
			if ( panel.classList.contains( 'panel-left' ) ) left = width;
			else right = width;

		}
		this.onInsets( left, right, this._barCover( left, right ) );

	}

	// The timeline bar floats over the bottom of the view: where it spans the whole
	// part the side panels leave free, the canvas ends above it.
	_barCover( left, right ) {

		if ( ! this._bar || this._bar.hidden ) return 0;
		const bar = this._bar.getBoundingClientRect();
		const spans = bar.left <= left && bar.right >= window.innerWidth - right;
		return spans ? Math.max( 0, Math.ceil( window.innerHeight - bar.top ) ) : 0;

	}

	dispose() {

		this.narrow.removeEventListener( 'change', this._onNarrow );
		window.removeEventListener( 'resize', this._onResize );
		this._observer.disconnect();
		this._barObserver.disconnect();

	}

}

export { Panels };

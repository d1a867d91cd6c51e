import * as THREE from 'three';
import { canvasSprite } from './canvas_sprite.js';

// Drawn in the view, not as HTML over it: in Chromium's default path without a GPU
// (SwiftShader in the GPU process), three small tags over the canvas cost the page
// 37.5 -> 45.4 frames/s, even resting and without their shadows (bench/page_fps.py).
// As sprites they are part of the picture both views already draw.
const FONT = 'system-ui, sans-serif';
const NAME_PX = 12; // CSS px, as the panels' text
const NOTE_PX = 11;
const PAD_X = 8;
const PAD_Y = 3;
const EDGE_PX = 3; // the robot's colour down the tag's left side
const MAX_WIDTH_PX = 260;
const LIFT_PX = 2; // the tag's foot above its anchor
const BAD = '#d6352b'; // --bad in linkview.css
const DARK = window.matchMedia( '(prefers-color-scheme: dark)' );
const _ndc = new THREE.Vector3();

/** `text` broken into lines no wider than `width` px (by words; a long word by letters). */
function wrapped( ctx, text, width ) {

	const lines = [];
	let line = '';
	for ( const word of text.split( /\s+/ ) ) {

		const next = line ? `${line} ${word}` : word;
		if ( ctx.measureText( next ).width <= width ) {

			line = next;
			continue;

		}
		if ( line ) lines.push( line );
		line = '';
		for ( const letter of word ) {

			if ( ctx.measureText( line + letter ).width > width && line ) {

				lines.push( line );
				line = '';

			}
			line += letter;

		}

	}
	if ( line ) lines.push( line );
	return lines;

}

/** One robot's tag: its name on a panel edged in its colour, and its note (why it is not live) below in red. */
class Tag {

	constructor( name ) {

		this.name = name;
		this.note = null;
		this.color = null;
		this.dark = false;
		Object.assign( this, canvasSprite() ); // canvas, ctx, texture, sprite
		this.texture.minFilter = THREE.LinearFilter; // drawn at its size on screen: no mipmaps
		this.texture.generateMipmaps = false;
		this.sprite.center.set( 0.5, 0 ); // its foot at the anchor
		this.sprite.renderOrder = 13; // over the robots and the world axes' letters
		this.sprite.name = `${name} label`;
		this.sprite.visible = false;
		this.scale = 0; // device px per CSS px it was drawn at
		this.heightPx = 0; // CSS px
		this.widthPx = 0;

	}

	/** Draw the tag for `note` and `color` (a THREE.Color) at `scale` device px per CSS px, if anything changed. */
	draw( note, color, scale ) {

		const dark = DARK.matches;
		const hex = color.getHex();
		if ( note === this.note && hex === this.color && scale === this.scale && dark === this.dark ) return;
		this.note = note;
		this.color = hex;
		this.scale = scale;
		this.dark = dark;
		const ctx = this.ctx;
		const nameFont = `600 ${NAME_PX}px ${FONT}`;
		const noteFont = `500 ${NOTE_PX}px ${FONT}`;
		ctx.font = noteFont;
		const noteLines = note ? wrapped( ctx, note, MAX_WIDTH_PX - 2 * PAD_X - EDGE_PX ) : [];
		ctx.font = nameFont;
		let width = ctx.measureText( this.name ).width;
		ctx.font = noteFont;
		for ( const line of noteLines ) width = Math.max( width, ctx.measureText( line ).width );
		this.widthPx = Math.ceil( Math.min( width, MAX_WIDTH_PX ) + 2 * PAD_X + EDGE_PX );
		this.heightPx = Math.ceil( 2 * PAD_Y + NAME_PX * 1.35 + noteLines.length * NOTE_PX * 1.35 );
		this.canvas.width = Math.round( this.widthPx * scale );
		this.canvas.height = Math.round( this.heightPx * scale );
		ctx.setTransform( scale, 0, 0, scale, 0, 0 ); // resizing reset it
		ctx.fillStyle = dark ? 'rgba(28, 32, 40, 0.9)' : 'rgba(255, 255, 255, 0.93)'; // --panel
		ctx.beginPath();
		ctx.roundRect( 0, 0, this.widthPx, this.heightPx, 6 );
		ctx.fill();
		ctx.fillStyle = `#${color.getHexString()}`;
		ctx.fillRect( 0, 0, EDGE_PX, this.heightPx );
		ctx.textBaseline = 'top';
		ctx.font = nameFont;
		ctx.fillStyle = dark ? '#e3e7ee' : '#1d2430'; // --ink
		ctx.fillText( this.name, PAD_X + EDGE_PX, PAD_Y + 1, MAX_WIDTH_PX - 2 * PAD_X );
		ctx.font = noteFont;
		ctx.fillStyle = BAD;
		noteLines.forEach( ( line, i ) => ctx.fillText( line, PAD_X + EDGE_PX, PAD_Y + 1 + ( NAME_PX + i * NOTE_PX ) * 1.35 ) );
		this.texture.dispose(); // a new size: a new texture on the GPU
		this.texture.needsUpdate = true;

	}

	dispose() {

		this.texture.dispose();
		this.sprite.material.dispose();

	}

}

/**
 * Robot name tags above the robots, with a robot's note under its name while it is
 * not live (its error, or why it is grey); `shown` turns them all off.
 */
class Labels {

	constructor( scene ) {

		this.group = new THREE.Group();
		this.group.name = 'labels';
		scene.add( this.group );
		this.shown = true;
		this._tags = new Map(); // robot name -> Tag

	}

	/** One tag per view, coloured like the robot. */
	rebuild( views ) {

		this.dispose();
		for ( const name of views.keys() ) {

			const tag = new Tag( name );
			this.group.add( tag.sprite );
			this._tags.set( name, tag );

		}

	}

	/** Place each tag at its robot's anchor, its size in CSS px as `stage` (scene.js) shows it. */
	update( views, stage ) {

		const scale = stage.renderer.getPixelRatio();
		const { width, height } = stage.viewRect;
		const projection = stage.camera.projectionMatrix.elements;
		for ( const [ name, tag ] of this._tags ) {

			const view = views.get( name );
			const sprite = tag.sprite;
			sprite.visible = this.shown && Boolean( view && view.anchor && view.group.visible );
			if ( ! sprite.visible ) continue;
			tag.draw( view.note ?? null, view.color, scale );
			// sizeAttenuation off: a sprite `s` high is s * P[5] / 2 of the view's height.
			const high = 2 * tag.heightPx / ( height * projection[ 5 ] );
			const wide = 2 * tag.widthPx / ( width * projection[ 0 ] );
			if ( sprite.scale.x !== wide || sprite.scale.y !== high ) sprite.scale.set( wide, high, 1 );
			sprite.position.copy( view.anchor );
			sprite.center.y = - LIFT_PX / tag.heightPx;

		}

	}

	/** What each tag shows, for tests: { robot, text, note, shown, x, y } (x, y: its foot, container px). */
	described( stage ) {

		return [ ...this._tags.values() ].map( ( tag ) => {

			const at = tag.sprite.visible ? stage.toContainer( _ndc.copy( tag.sprite.position ).project( stage.camera ) ) : null;
			const onScreen = at !== null && _ndc.z < 1 && Math.abs( _ndc.x ) <= 1 && Math.abs( _ndc.y ) <= 1;
			return { robot: tag.name, text: tag.name, note: tag.note, shown: onScreen, x: at && at.x, y: at && at.y };

		} );

	}

	dispose() {

		for ( const tag of this._tags.values() ) {

			this.group.remove( tag.sprite );
			tag.dispose();

		}
		this._tags.clear();

	}

}

export { Labels };

import * as THREE from 'three';
import { canvasSprite } from './canvas_sprite.js';

const AXIS_M = 0.6; // world axes' length: out of the base of a robot standing at the origin
const LETTER_SCALE = 0.026; // sprite height as a share of the view's height, times 2 tan(fov / 2)
const TEXT_PX = 48; // canvas font size; the sprite scales it to LETTER_SCALE on screen
const AXES = [
	{ name: 'X', dir: [ 1, 0, 0 ], color: '#e0412f' },
	{ name: 'Y', dir: [ 0, 1, 0 ], color: '#2f9e44' },
	{ name: 'Z', dir: [ 0, 0, 1 ], color: '#2f6fd6' },
];

/** A text sprite (canvas_sprite.js) `height` high, as a share of the view's height times 2 tan(fov / 2). */
function textSprite( text, color, height = LETTER_SCALE ) {

	const { canvas, ctx, sprite } = canvasSprite();
	const font = `600 ${TEXT_PX}px system-ui, sans-serif`;
	ctx.font = font;
	canvas.width = Math.ceil( ctx.measureText( text ).width ) + 16;
	canvas.height = TEXT_PX + 16;
	ctx.font = font; // resizing the canvas reset it
	ctx.textAlign = 'center';
	ctx.textBaseline = 'middle';
	ctx.lineWidth = 8;
	ctx.strokeStyle = 'rgba(255, 255, 255, 0.85)'; // legible on the light floor and on dark meshes
	ctx.lineJoin = 'round';
	ctx.strokeText( text, canvas.width / 2, canvas.height / 2 );
	ctx.fillStyle = color;
	ctx.fillText( text, canvas.width / 2, canvas.height / 2 );
	sprite.scale.set( height * canvas.width / canvas.height, height, 1 );
	sprite.renderOrder = 12;
	sprite.name = text;
	return sprite;

}

/**
 * Orientation aids in the view: the world axes from the origin, labelled X, Y, Z
 * at their tips, and the floor grid's spacing written on the floor ("grid 250 mm").
 * Static: built once, and again only when the grid changes.
 */
class OrientationAids {

	constructor( scene ) {

		this.group = new THREE.Group();
		this.group.name = 'orientation';
		const axes = new THREE.AxesHelper( AXIS_M );
		axes.setColors( ...AXES.map( ( axis ) => new THREE.Color( axis.color ) ) );
		this.group.add( axes );
		this.axes = axes;
		this.letters = AXES.map( ( axis ) => {

			const letter = textSprite( axis.name, axis.color );
			letter.position.fromArray( axis.dir ).multiplyScalar( AXIS_M * 1.1 );
			this.group.add( letter );
			return letter;

		} );
		this.gridLabel = null;
		this.gridText = '';
		scene.add( this.group );

	}

	/** Write the grid's spacing (m) on the floor, in the middle of one cell in front of the origin. */
	setGridSpacing( spacingM ) {

		const text = `grid ${Math.round( spacingM * 1000 )} mm`;
		if ( text === this.gridText ) return;
		this._disposeGridLabel();
		this.gridText = text;
		this.gridLabel = textSprite( text, '#4a5260', 0.6 * LETTER_SCALE ); // a note, not a heading
		this.gridLabel.position.set( 2.5 * spacingM, - 2.5 * spacingM, 0 );
		this.group.add( this.gridLabel );

	}

	/** For tests: each label's text and where it is in the view's container (CSS px), if in the view. */
	onScreen( stage ) {

		const at = new THREE.Vector3();
		return [ ...this.letters, this.gridLabel ].filter( Boolean ).map( ( sprite ) => {

			sprite.getWorldPosition( at ).project( stage.camera );
			const { x, y } = stage.toContainer( at );
			return { text: sprite.name, x, y, inView: Math.abs( at.x ) <= 1 && Math.abs( at.y ) <= 1 && at.z <= 1 };

		} );

	}

	_disposeGridLabel() {

		if ( ! this.gridLabel ) return;
		this.gridLabel.removeFromParent();
		this.gridLabel.material.map.dispose();
		this.gridLabel.material.dispose();
		this.gridLabel = null;

	}

	dispose() {

		this._disposeGridLabel();
		for ( const letter of this.letters ) {

			letter.material.map.dispose();
			letter.material.dispose();

		}
		this.axes.dispose();
		this.group.removeFromParent();

	}

}

export { OrientationAids };
